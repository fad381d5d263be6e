"""Layer 1, the kernels: the C Bellman-row kernels (row sweeps, Q-values, the game operator,
the post-decision form, the aggregation of rows), their numpy twins (the tests' reference),
and the one thread pool they run on."""
