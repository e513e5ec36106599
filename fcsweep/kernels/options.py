"""Compile options shared by every numba kernel.

``error_model="numpy"`` lets loops containing divisions vectorise; ``reassoc`` and
``contract`` let LLVM vectorise floating-point sums.  ``nnan``/``ninf`` stay off so that
the finiteness checks of the step remain valid.  ``cache=True`` writes compiled code next
to the sources, or to ``NUMBA_CACHE_DIR`` when set (read-only installs).
"""

FASTMATH = {"reassoc", "contract", "nsz", "arcp"}
NJIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH)
