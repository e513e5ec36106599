"""A run's physics versus its length: what a finished run still needs under a config.

The reuse fingerprint of a run (:func:`fcsweep.sweep.runner.fingerprint_of`) holds what
defines its trajectory frame by frame -- run id (the model parameters and replicate),
seed, ``sample_every`` and the stored fields -- and not its length (``run.steps``,
``run.until``).  Fingerprints written before this split also held ``steps``; they are
compared without it, so sweeps computed by earlier versions stay reusable and extendable.

A finished run (``status.json`` says ``done``) needs more steps when

- it stopped at its cap (``stop_reason`` "steps") and ``run.steps`` is now larger, or
- it stopped because it was settled under ``run.until`` settings (or a ``run.transient``,
  which the check's analysis uses) other than the present ones and ``run.steps`` is
  larger than what it did.

It is then *extended*: continued from its final checkpoint, so that its trajectory is bit
for bit the one a run with the new settings from the start would have written (for a
changed ``until`` this holds when the new targets are not met before the step at which
the run stopped: frames are never taken back).
"""

from __future__ import annotations

import json
from typing import Any, Mapping

from fcsweep.config import RunSettings

__all__ = ["LENGTH_KEYS", "physics_of", "same_physics", "extension_of", "frames_done", "STOP_SETTLED",
           "STOP_STEPS", "STOP_FAILED"]

#: Fingerprint keys that describe a run's length, not its physics (old fingerprints only).
LENGTH_KEYS = ("steps",)
#: ``status.json`` ``stop_reason`` values.
STOP_SETTLED, STOP_STEPS, STOP_FAILED = "settled", "steps", "failed"


def physics_of(fingerprint: str | None) -> dict[str, Any] | None:
    """The physics part of a fingerprint (``None`` if it is not a JSON object)."""
    try:
        fp = json.loads(fingerprint) if fingerprint else None
    except (TypeError, ValueError):
        return None
    if not isinstance(fp, dict):
        return None
    return {k: v for k, v in fp.items() if k not in LENGTH_KEYS}


def same_physics(a: str | None, b: str | None) -> bool:
    """Whether two fingerprints describe the same trajectory up to its length."""
    pa = physics_of(a)
    return pa is not None and pa == physics_of(b)


def extension_of(run: RunSettings, status: Mapping[str, Any]) -> str | None:
    """What a done run still needs under ``run``: ``None`` (nothing) or a short reason
    why it will be extended (``"to 2000000 steps"``, ``"until changed"``).

    Parameters
    ----------
    run : RunSettings
        The present config's run section.
    status : mapping
        The run's ``status.json`` (or the ``/parameters`` of its trajectory), with
        ``steps_done``, ``stop_reason`` and, for a settled run, ``until`` and ``transient``.
    """
    done = int(status.get("steps_done", 0) or 0)
    if done >= run.steps:
        return None
    if status.get("stop_reason", STOP_STEPS) == STOP_SETTLED:
        until = status.get("until")
        if isinstance(until, str):
            try:
                until = json.loads(until)
            except ValueError:
                until = None
        transient = status.get("transient", run.transient)  # status files before it was recorded
        if run.until is not None and until == run.until.as_dict() and float(transient) == run.transient:
            return None
        return f"settled under other run.until (or transient) settings; continue to check up to {run.steps} steps" \
            if run.until is not None else f"settled earlier; run.until removed: to {run.steps} steps"
    return f"to {run.steps} steps"


def frames_done(run: RunSettings, status: Mapping[str, Any]) -> int:
    """Frames in a done run's trajectory: steps done / sample_every + 1 (status files
    written before ``steps_done`` could differ from the cap: the cap)."""
    return int(status.get("steps_done", run.steps)) // run.sample_every + 1
