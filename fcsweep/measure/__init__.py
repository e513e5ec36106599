"""Measure segmented images of cell monolayers with the simulation's observables
(``fcsweep measure``; docs/measure.md).

It sits beside :mod:`fcsweep.analysis`: it imports analysis, model and io, never the sweep
runner or the CLI.

The package is callable: ``fcsweep.measure(labels, pixel_size=1.0, frame_interval=1.0, ...)``
is :func:`fcsweep.measure.dataset.measure`.
"""

import sys
import types

from fcsweep.measure.dataset import OUTPUT_NAME, VARIABLES, measure, measure_to_file, write_measure
from fcsweep.measure.readers import MeasureInputError, iter_frames, read_seg_npy

__all__ = ["measure", "measure_to_file", "write_measure", "iter_frames", "read_seg_npy", "MeasureInputError",
           "VARIABLES",
           "OUTPUT_NAME"]


class _CallableModule(types.ModuleType):
    """``fcsweep.measure(...)`` calls :func:`measure` (the issue's spelling of the Python API)."""

    def __call__(self, *args, **kwargs):
        return measure(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
