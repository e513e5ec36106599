"""``status.json`` of a run: written atomically (tmp + rename), read tolerantly."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping

from fcsweep.io.atomic import atomic_write
from fcsweep.io.schema import STATUS

__all__ = ["write_status", "read_status"]


def write_status(run_dir, data: Mapping[str, Any]) -> None:
    """Replace ``run_dir/status.json`` with ``data`` atomically."""
    def write(tmp: Path) -> None:
        with open(tmp, "w") as fh:
            json.dump(dict(data), fh, indent=1, sort_keys=True)
            fh.write("\n")

    atomic_write(Path(run_dir) / STATUS, write)


def read_status(run_dir) -> dict[str, Any] | None:
    """The run's status dict, or ``None`` if there is none (or it is unreadable)."""
    path = Path(run_dir) / STATUS
    try:
        with open(path) as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
