"""File formats of a sweep: H5MD trajectories, checkpoints, status files and run locks.

Layouts are documented in ``results_schema.md``; names used by more than one module live
in :mod:`fcsweep.io.schema`.
"""
