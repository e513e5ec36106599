"""fcsweep: simulate and sweep the Fourier contour cell model of active deformable cells."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("fcsweep")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__", "measure"]


def __getattr__(name):
    # ``fcsweep.measure(labels, ...)`` without importing xarray & co. on ``import fcsweep``
    if name == "measure":
        import importlib

        return importlib.import_module("fcsweep.measure")
    raise AttributeError(f"module 'fcsweep' has no attribute {name!r}")
