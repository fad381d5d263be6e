"""Layer 8, studies: solver comparisons and their reports, performance profiles,
verification campaigns and LP export."""
