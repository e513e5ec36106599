"""Numba kernels of the contour model (ndarrays and scalars in, no Python objects).

Compiled code is cached on disk, in a directory named after a hash of the kernel
sources (:func:`cache_dir`; :mod:`fcsweep.kernels.cache` says why and where).
Importing the package changes no process-wide setting: each kernel carries its own
cache locator (:func:`fcsweep.kernels.options.njit`).
"""

from __future__ import annotations

from .cache import cache_dir

__all__ = ["cache_dir"]
