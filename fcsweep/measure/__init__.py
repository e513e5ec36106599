"""Measure segmented images of cell monolayers with the simulation's observables
(``fcsweep measure``; docs/measure.md).

It sits beside :mod:`fcsweep.analysis`: it imports analysis, model and io, never the sweep
runner or the CLI.
"""

from fcsweep.measure.dataset import OUTPUT_NAME, VARIABLES, measure, write_measure
from fcsweep.measure.readers import MeasureInputError, iter_frames, read_seg_npy

__all__ = ["measure", "write_measure", "iter_frames", "read_seg_npy", "MeasureInputError", "VARIABLES",
           "OUTPUT_NAME"]
