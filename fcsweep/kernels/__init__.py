"""Numba kernels of the contour model (ndarrays and scalars in, no Python objects).

Compiled code is cached on disk (``cache=True``).  Numba invalidates a cache entry only
when the file of that very function changes, not when a function it inlines from another
module does, nor when a module-level constant it reads from another module changes (the
contact-arc constants live in :mod:`fcsweep.model.rates`); a stale entry can then crash
or silently compute with old constants.  The cache therefore lives in a directory named
after a hash of all kernel and model sources::

    $NUMBA_CACHE_DIR/fcsweep-<hash>   if NUMBA_CACHE_DIR is set (read-only installs,
                                       clusters: point it at a writable scratch path)
    ~/.cache/fcsweep/numba-<hash>     otherwise ($XDG_CACHE_HOME is honoured)
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba.core.config as _nb_config


def _configure_cache() -> str:
    here = Path(__file__).parent
    h = hashlib.sha256()
    for f in sorted(here.glob("*.py")) + sorted((here.parent / "model").glob("*.py")):
        h.update(f"{f.parent.name}/{f.name}".encode())
        h.update(f.read_bytes())
    tag = h.hexdigest()[:12]
    base = os.environ.get("NUMBA_CACHE_DIR")
    if base:
        path = os.path.join(base, f"fcsweep-{tag}")
    else:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        path = os.path.join(xdg, "fcsweep", f"numba-{tag}")
    _nb_config.CACHE_DIR = path
    return path


CACHE_DIR = _configure_cache()
