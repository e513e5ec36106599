"""``<output>/refinement.json``: grid points that ``fcsweep refine`` added to a sweep.

The user's YAML is never edited; the points live with the results they produced, so
every command that reads the sweep (status, list-runs, simulate --task-index, analyze,
aggregate, plot) sees them through :meth:`fcsweep.config.SweepConfig.runs`.  Layout::

    {"version": 1,
     "rounds": [{"round": 1, "created": "2026-...", "points": [{"eta": 0.0316, "v0": 0.03}, ...],
                 "why": ["eta between 0.01 (solid) and 0.1 (fluid) at v0=0.03", ...]}, ...]}

Points hold the swept parameters only; their order (round by round) is the order of the
runs they add after the product grid, so run indices never change.  The file is replaced
atomically.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

from fcsweep.io.schema import REFINEMENT
from fcsweep.io.atomic import atomic_write

__all__ = ["REFINEMENT_FILE", "RefinementError", "read_rounds", "read_points", "append_round"]

REFINEMENT_FILE = REFINEMENT
VERSION = 1


class RefinementError(ValueError):
    """An unreadable or malformed refinement file."""


def read_rounds(output) -> list[dict[str, Any]]:
    """Every recorded round (``[]`` when the sweep was never refined)."""
    path = Path(output) / REFINEMENT_FILE
    try:
        text = path.read_text()
    except (FileNotFoundError, NotADirectoryError):  # no file, or no output directory (yet)
        return []
    except OSError as exc:
        raise RefinementError(f"cannot read {path}: {exc.strerror}") from None
    try:
        data = json.loads(text)
        rounds = data["rounds"]
        if int(data.get("version", 0)) != VERSION or not isinstance(rounds, list):
            raise ValueError("unknown layout")
        for r in rounds:
            if not all(isinstance(p, dict) for p in r["points"]):
                raise ValueError("a point is not a mapping")
    except (ValueError, KeyError, TypeError) as exc:
        raise RefinementError(f"{path} is not a refinement file of version {VERSION} ({exc})") from None
    return rounds


def read_points(output) -> list[dict[str, Any]]:
    """All added points, in the order they were added."""
    return [dict(p) for r in read_rounds(output) for p in r["points"]]


def append_round(output, points: Sequence[Mapping[str, Any]], why: Sequence[str], created: str) -> int:
    """Record one more round of points; returns its number (1, 2, ...)."""
    path = Path(output) / REFINEMENT_FILE
    rounds = read_rounds(output)
    number = len(rounds) + 1
    rounds.append({"round": number, "created": created, "points": [dict(p) for p in points],
                   "why": list(why)})
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps({"version": VERSION, "rounds": rounds}, indent=1) + "\n"
    atomic_write(path, lambda tmp: tmp.write_text(text))
    return number
