"""Parameter studies: point sets (grids, seeded random samples), one engine that evaluates them
in batches, backends (this process, local processes, a Dask cluster) and incremental output.

The evaluators (threshold maps, gain studies, robustness) are in :mod:`rotor_avc.analysis`.
Imports only the numpy/scipy core; Dask is imported when a cluster is used.
"""
