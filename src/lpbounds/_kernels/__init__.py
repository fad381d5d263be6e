"""Layer 1, the kernels: compiled (numba) sweeps, their numpy twins, the aggregation
kernels and the dispatch between them."""
