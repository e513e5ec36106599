"""Atomic checkpoint files (``checkpoint.npz``) of one run.

A checkpoint is the engine's :meth:`Simulation.to_checkpoint` dict plus bookkeeping keys
prefixed ``_sweep_`` (frames committed to the trajectory, run id, settings fingerprint).
It is written to a temporary file in the same directory, fsynced, and moved into place
with :func:`os.replace`, so a reader sees either the previous checkpoint or the new one,
never a partial file, whatever moment the writer is killed.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from fcsweep.io.sweepdir import atomic_write, fsync_dir

__all__ = ["save_checkpoint", "load_checkpoint", "split_meta", "META_PREFIX", "fsync_dir"]

META_PREFIX = "_sweep_"


def save_checkpoint(
    path,
    state: Mapping[str, Any],
    meta: Mapping[str, Any],
    *,
    before_replace: Callable[[Path], None] | None = None,
) -> None:
    """Write ``state`` (engine checkpoint dict) and ``meta`` atomically to ``path``.

    Parameters
    ----------
    path : path-like
        Destination ``.npz``.
    state : mapping of str -> ndarray / int / float / str
    meta : mapping
        Bookkeeping, stored under ``_sweep_<key>``.
    before_replace : callable, optional
        Called with the temporary path after it is written and before the rename
        (test hook for kills during a checkpoint write).
    """
    arrays = {k: np.asarray(v) for k, v in state.items()}
    arrays.update({META_PREFIX + k: np.asarray(v) for k, v in meta.items()})

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)

    atomic_write(path, write, fsync=True, before_replace=before_replace)


def load_checkpoint(path, keys=None) -> dict[str, Any] | None:
    """Read a checkpoint (only the entries ``keys`` if given); ``None`` if it is missing or
    unreadable.

    0-d arrays come back as Python scalars (``int``, ``float``, ``str``).
    """
    path = Path(path)
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            names = z.files if keys is None else [k for k in keys if k in z.files]
            return {k: (z[k].item() if z[k].ndim == 0 else z[k]) for k in names}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, KeyError):
        return None


def split_meta(ck: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Split a loaded checkpoint into (engine state dict, bookkeeping dict)."""
    state = {k: v for k, v in ck.items() if not k.startswith(META_PREFIX)}
    meta = {k[len(META_PREFIX):]: v for k, v in ck.items() if k.startswith(META_PREFIX)}
    return state, meta
