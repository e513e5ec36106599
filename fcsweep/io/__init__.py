"""File formats of a sweep: H5MD trajectories, checkpoints, status files and run locks.

Layouts are documented in ``results_schema.md``; names used by more than one module live
in :mod:`fcsweep.io.schema`.  Every file a reader may open while it is written goes
through :func:`fcsweep.io.atomic.atomic_write` (re-exported by :mod:`fcsweep.io.sweepdir`),
which sits below status, refinement, checkpoint and run-directory modules so that no
module of the package imports one that imports it back.
"""
