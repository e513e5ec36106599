"""Compile options shared by every numba kernel.

``error_model="numpy"`` lets loops containing divisions vectorise; ``contract`` lets
LLVM fuse multiply-adds.  ``reassoc`` stays off: with it, LLVM vectorised the per-cell
sums in an order that differed between a kernel compiled in the running process and the
same kernel loaded from numba's disk cache, so rates differed in the last bit and a
resumed run drifted away from an uninterrupted one.  Sums that matter for speed are
written with a fixed order instead (:func:`fcsweep.kernels.rates.cell_rates`).
``nnan``/``ninf`` stay off so that the finiteness checks of the step remain valid.
``cache=True`` (in :func:`njit`) caches the compiled code in the directory of
:func:`fcsweep.kernels.cache.cache_dir`, named after a hash of the kernel sources.
"""

import numba

from .cache import kernel_cache

FASTMATH = {"contract", "nsz", "arcp"}
NJIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH)


def njit(**options):
    """``numba.njit`` for the kernels: ``cache=True`` caches in
    :func:`fcsweep.kernels.cache.cache_dir` (the dispatcher's own cache, not numba's
    process-wide cache directory)."""
    cache = options.pop("cache", False)

    def decorate(py_func):
        dispatcher = numba.njit(**options)(py_func)
        if cache:
            found = kernel_cache(py_func)
            if found is not None:
                dispatcher._cache = found  # what Dispatcher.enable_caching() sets, with our locator
        return dispatcher

    return decorate
