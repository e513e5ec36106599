"""Where to add grid points: between neighbours whose labels differ or are undetermined.

``fcsweep refine`` maps a phase boundary by bisection.  After a round has been
simulated, analysed and aggregated, :func:`propose_points` looks along every swept axis
at each line of points that share all other swept values (the product grid's rows and
columns, and the lines that earlier rounds created), and proposes the midpoint of every
pair of neighbours on such a line whose point labels (``phase_point``,
``percolated_point`` of ``phase_diagram.nc``) differ, or of which one is undetermined.
Midpoints are geometric on axes given as ``log: true`` ranges, arithmetic otherwise
(integers: the integer midpoint, when there is one).  Pairs with differing determined
labels come first, then pairs with an undetermined end; within each, wider gaps
(relative to the axis range, in log units on log axes) first.

Why not python-adaptive: its learners pick points of a function that is evaluated once
per point; here a point's answer is a run that may still be continued (``run.until``
extends an undetermined run in time, refinement adds points in space), labels are
categorical with a confidence, and replicates and job arrays need a fixed, recorded set
of points per round.  The bisection rule is short, deterministic and reproducible from
``refinement.json``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

__all__ = ["Proposal", "propose_points", "point_labels"]

#: Codes of the point labels (see fcsweep.analysis.phase): -1 unknown (not analysed),
#: phase 3 and percolation 2 undetermined.
UNKNOWN = -1
UNDETERMINED = {"phase": 3, "percolated": 2}


@dataclass(frozen=True)
class Proposal:
    """A new grid point and why it was chosen."""

    point: dict
    why: str
    priority: tuple


def _round12(x: float) -> float:
    return float(f"{x:.12g}")


def _midpoint(a, b, log: bool):
    """Midpoint of two axis values, or ``None`` if there is none strictly between."""
    if isinstance(a, str) or isinstance(b, str):
        return None
    if isinstance(a, (int,)) and isinstance(b, (int,)) and not isinstance(a, bool):
        m = (a + b) // 2 if not log else int(round(math.sqrt(a * b)))
        return m if min(a, b) < m < max(a, b) else None
    a, b = float(a), float(b)
    m = _round12(math.sqrt(a * b)) if log and a > 0 and b > 0 else _round12(0.5 * (a + b))
    return m if min(a, b) < m < max(a, b) else None


def _describe(labels: Mapping[str, int], names: Mapping[str, Mapping[int, str]]) -> str:
    return "/".join(names.get(k, {}).get(v, str(v)) for k, v in labels.items())


def propose_points(
    labels: Mapping[tuple, Mapping[str, int]],
    axes: Sequence[str],
    *,
    log_axes: Sequence[str] = (),
    max_points: int | None = None,
    flag_names: Mapping[str, Mapping[int, str]] | None = None,
) -> list[Proposal]:
    """Midpoints between neighbours with differing or undetermined labels.

    Parameters
    ----------
    labels : mapping
        Point (tuple of swept values in ``axes`` order) -> ``{"phase": code,
        "percolated": code}``.  Points with an unknown (-1) label are not compared.
    axes : sequence of str
        Swept parameter names.
    log_axes : sequence of str
        Axes bisected geometrically.
    max_points : int, optional
        Most points returned (the highest priority ones).
    flag_names : mapping, optional
        Label -> code -> name, for the ``why`` texts.

    Returns
    -------
    list of Proposal
        In priority order; no point twice, none already in ``labels``.
    """
    flag_names = flag_names or {}
    existing = {tuple(p) for p in labels}
    spans = {}
    for i, a in enumerate(axes):
        vals = [p[i] for p in labels if not isinstance(p[i], str)]
        if len(vals) >= 2:
            lo, hi = min(vals), max(vals)
            log = a in log_axes and lo > 0
            spans[a] = (math.log(hi / lo) if log else float(hi - lo)) or 1.0
    found: dict[tuple, Proposal] = {}
    for i, a in enumerate(axes):
        if a not in spans:
            continue
        log = a in log_axes
        lines: dict[tuple, list[tuple]] = {}
        for p in labels:
            lines.setdefault(p[:i] + p[i + 1:], []).append(p)
        for line in lines.values():
            line.sort(key=lambda p: p[i])
            for p, q in zip(line, line[1:]):
                lp, lq = labels[p], labels[q]
                if any(v == UNKNOWN for v in (*lp.values(), *lq.values())):
                    continue
                differ = lp != lq
                undetermined = any(lp[k] == UNDETERMINED.get(k) or lq[k] == UNDETERMINED.get(k) for k in lp)
                if not (differ or undetermined):
                    continue
                m = _midpoint(p[i], q[i], log)
                if m is None:
                    continue
                new = p[:i] + (m,) + p[i + 1:]
                if new in existing or new in found:
                    continue
                gap = (math.log(q[i] / p[i]) if log and p[i] > 0 else float(q[i] - p[i])) / spans[a]
                rest = ", ".join(f"{axes[k]}={p[k]}" for k in range(len(axes)) if k != i)
                kind = "undetermined" if undetermined else "differ"
                why = (f"{a} between {p[i]} ({_describe(lp, flag_names)}) and {q[i]} "
                       f"({_describe(lq, flag_names)})" + (f" at {rest}" if rest else ""))
                prio = (0 if kind == "differ" else 1, -gap, i, tuple(str(v) for v in new))
                found[new] = Proposal(dict(zip(axes, new)), why, prio)
    out = sorted(found.values(), key=lambda pr: pr.priority)
    return out[:max_points] if max_points is not None else out


def point_labels(ds, runs: Sequence[Any], axes: Sequence[str]) -> dict[tuple, dict[str, int]]:
    """Point labels of every grid point of ``runs`` from an aggregated dataset.

    Parameters
    ----------
    ds : xarray.Dataset
        ``phase_diagram.nc`` (variables ``phase_point`` and ``percolated_point``).
    runs : sequence of RunSpec
    axes : sequence of str
        Swept parameter names.
    """
    out = {}
    for spec in runs:
        key = tuple(spec.params[a] for a in axes)
        if key in out:
            continue
        sel = {d: spec.params[d] for d in ds["phase_point"].dims}
        out[key] = {"phase": int(ds["phase_point"].sel(sel).item()),
                    "percolated": int(ds["percolated_point"].sel(sel).item())}
    return out
