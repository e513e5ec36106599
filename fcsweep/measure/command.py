"""The work of ``fcsweep measure``: parse the unit options, measure, write ``OUT/measure.nc``."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from fcsweep.measure.dataset import measure_to_file
from fcsweep.measure.readers import MeasureInputError
from fcsweep.model.settings import PERCOLATION_THRESHOLD

__all__ = ["parse_pixel_size", "parse_times", "measure_to_dir", "EXAMPLE", "EXAMPLE_PIXEL_SIZE"]

#: The built-in example: 12 frames of 64 cells simulated at eta = 0.01, v0 = 0.06, 1 time
#: unit apart, rendered at 10 px per R0 (benchmarks/measure_example.py writes it).
EXAMPLE = Path(__file__).resolve().parent.parent / "data" / "measure_example.npy"
#: Pixel size of the example in units of R0.
EXAMPLE_PIXEL_SIZE = "0.1"


def parse_pixel_size(text: str | None):
    """``"X"`` or ``"X,Y"`` as (px, py), None for None; :class:`MeasureInputError` otherwise."""
    if text is None:
        return None
    try:
        parts = [float(p) for p in str(text).split(",")]
    except ValueError:
        parts = []
    if len(parts) not in (1, 2) or not all(p > 0 and p < float("inf") for p in parts):
        raise MeasureInputError(f"--pixel-size must be X or X,Y with positive numbers, got {text!r}")
    return (parts[0], parts[-1])


def parse_times(text: str | None):
    """Comma-separated time stamps, or None."""
    if not text:
        return None
    try:
        return [float(t) for t in text.split(",")]
    except ValueError:
        raise MeasureInputError(f"--times must be comma-separated numbers, one per frame, increasing "
                                f"(e.g. 0,2.5,5), got {text!r}") from None


def measure_to_dir(images, out, *, pixel_size: str | None = None, frame_interval: float | None = None,
                   length_unit: str | None = None, time_unit: str | None = None, times: str | None = None,
                   modes: int = 6,
                   percolation_threshold: float = PERCOLATION_THRESHOLD, v0: float | None = None,
                   Dr: float | None = None, neighbours: str = "voronoi", label_binary: bool = False) -> Path:
    """Measure ``images`` (paths) and write ``out/measure.nc``, streaming
    (:func:`fcsweep.measure.dataset.measure_to_file`); None options come from the
    TIFF's metadata or default to 1 (:func:`fcsweep.measure.calibration.resolve`).
    Without images, the built-in :data:`EXAMPLE` (lengths in R0, times in model units).
    Warnings of the measurement (e.g. a contact graph that leaves most cells alone) are
    written to stderr as one line each, ``warning: ...``.

    Raises
    ------
    MeasureInputError
        Unusable input or options.
    ImportError
        A reader of the ``measure`` extra is missing.
    fcsweep.io.failures.WriteFailure
        The file could not be written.
    """
    if not images:
        images = [EXAMPLE]
        pixel_size = pixel_size or EXAMPLE_PIXEL_SIZE
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        path = measure_to_file(list(images), out, parse_pixel_size(pixel_size), frame_interval, modes=modes,
                               length_unit=length_unit, time_unit=time_unit, times=parse_times(times),
                               percolation_threshold=percolation_threshold, v0=v0, Dr=Dr, neighbours=neighbours,
                               label_binary=label_binary, attrs={"source": " ".join(str(p) for p in images)})
    for w in caught:
        if issubclass(w.category, UserWarning):
            print(f"warning: {w.message}", file=sys.stderr)
    return path
