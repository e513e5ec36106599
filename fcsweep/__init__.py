"""fcsweep: simulate and sweep the Fourier contour cell model of active deformable cells."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("fcsweep")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
