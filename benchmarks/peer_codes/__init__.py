"""The peers the benchmarks set beside jaxcontact: NumPy, scipy, shapely, jax-md and libigl
forms (``baselines``), a hand-written numba grid (``numba_grid``) and IPC Toolkit (``ipc``).
Optional packages are imported where used; a missing one is reported, never a crash."""
