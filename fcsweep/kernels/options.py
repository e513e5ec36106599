"""Compile options shared by every numba kernel.

``error_model="numpy"`` lets loops containing divisions vectorise; ``contract`` lets
LLVM fuse multiply-adds.  ``reassoc`` stays off: with it, LLVM vectorised the per-cell
sums in an order that differed between a kernel compiled in the running process and the
same kernel loaded from numba's disk cache, so rates differed in the last bit and a
resumed run drifted away from an uninterrupted one.  Sums that matter for speed are
written with a fixed order instead (:func:`fcsweep.kernels.rates.cell_rates`).
``nnan``/``ninf`` stay off so that the finiteness checks of the step remain valid.
``cache=True`` writes compiled code next to the sources, or to ``NUMBA_CACHE_DIR`` when
set (read-only installs).
"""

FASTMATH = {"contract", "nsz", "arcp"}
NJIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH)
