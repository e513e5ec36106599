"""Figures over the eta x v0 plane: the phase diagram, D_eff against eta and the
KTHNY summary diagram (Fig. 2d, Fig. 4e)."""

from __future__ import annotations

import re
import textwrap

from matplotlib.collections import LineCollection
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from fcsweep.analysis.diffusion import D_EFF_SOLID
from fcsweep.results.figures.common import (CAPTION_SIZE, COLUMN, ETA_LABEL, OKABE_ITO, PHASE_COLORS, V0_LABEL,
                                            V0_SYMBOL, caption, caption_chars, cell_edges, error_of, eta_axis,
                                            flag_words, grid_ticks, log_axis, on_plane, own_axes, phase_words,
                                            reduce_to, styled, tidy_log, value_colorbar, value_colors)
from fcsweep.analysis.phase import KTHNY_FLAGS, RHO_D_PERCOLATION
from fcsweep.analysis.reasons import reason_short, reason_value
from fcsweep.model.shape import Q_STAR


#: Short words for the reasons a label is undetermined (``phase_reason``, ``kthny_reason``):
#: (pattern, words), the first pattern found in a clause wins.
SHORT_REASONS = (
    (r"not available|no data|not analysed|nothing ran", "no data"),
    (r"too short", "too short"),
    (r"replicates disagree", "replicates disagree"),
    (r"replicate's .*not trustworthy", "replicate not trusted"),
    (r"no cage broken|cages? not broken|not left their cages|left their cages", "cage not broken"),
    (r"cages may be broken", "cage may be broken"),
    (r"cages broken .* reads solid", "cages vs D_eff"),
    (r"<q>.*too close", "<q> near 3.81"),
    (r"rho_d.*too close", "rho_d near 1/2"),
    (r"D_eff.*too close", "near threshold"),
    (r"block length", "block-length dependent"),
    (r"reads fluid", "D_eff fluid"),
    (r"not diffusive|not settled|not trustworthy|still being explored", "not settled"),
    (r"no error estimate", "no error"),
    (r"^a longer run", None),  # advice, not a reason
)


def short_reason(text, words: int = 3) -> str:
    """A label's reason in two or three words, for drawing next to the point.

    Each ``;``-separated clause of ``text`` is matched against :data:`SHORT_REASONS`
    (run too short -> "too short", D_eff too close to 1e-3 -> "near threshold", <q> too
    close to 3.81 -> "<q> near 3.81", no cage broken -> "cage not broken", MSD not
    diffusive -> "not settled", no estimate -> "no data"); an unknown clause gives its
    first ``words`` words.  At most two clauses are kept, joined by ", ".

    Parameters
    ----------
    text : str
        A reason as the analysis writes it (``phase_reason`` and the like).
    words : int
        Words kept of a clause that no pattern matches.

    Returns
    -------
    str
        "" for an empty reason.
    """
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    out = []
    for clause in str(text or "").split(";"):
        clause = clause.strip()
        if not clause:
            continue
        hit = next(((pat, w) for pat, w in SHORT_REASONS if re.search(pat, clause, re.IGNORECASE)), None)
        if hit is None:
            short = " ".join(re.sub(r"\(.*?\)", "", clause).split()[:words]).rstrip(":,")
        elif hit[1] is None:
            continue
        else:
            short = hit[1]
        if short and short not in out:
            out.append(short)
    return ", ".join(out[:2])


def _point_reasons(ds, keep, select, label="phase") -> np.ndarray:
    """The reason of every point of the plane in short words; over replicates and starts
    (``initial``), the first run's whose label is not accepted (undetermined or unknown),
    or "replicates disagree" / "starts disagree" where accepted labels differ (the
    replicates of one start first). The words come from ``<label>_reason_code``
    (:func:`fcsweep.analysis.reasons.reason_short`); only where a run has no code (a
    dataset written before the codes, such as those under campaigns/archive, or code
    ``not_recorded``) from the reason text by :func:`short_reason`."""
    name, cname = f"{label}_reason", f"{label}_reason_code"
    codes = ds[label]
    shape = tuple(ds.sizes[d] for d in keep)
    if name not in ds and cname not in ds:
        return np.full(shape, "", dtype=object)
    blank = xr.full_like(codes, "", dtype=object)
    text_da = ds[name] if name in ds else blank
    rc_da = ds[cname] if cname in ds else xr.zeros_like(codes)
    words = flag_words(codes)
    bad = [c for c, w in words.items() if w in ("undetermined", "unknown")]
    over = tuple(d for d in ("initial", "replicate") if d in codes.dims and d not in keep)
    n_start = ds.sizes["initial"] if "initial" in over else 1

    def plane(da):  # per point: (starts, replicates), length 1 where not reduced
        da = da.load().broadcast_like(codes)
        return reduce_to(da, tuple(keep) + over, select).values.reshape(shape + (n_start, -1))

    text, rc, code = plane(text_da), plane(rc_da), plane(codes)
    out = np.full(shape, "", dtype=object)
    for idx in np.ndindex(*shape):
        c = code[idx].astype(int)
        ok = ~np.isin(c, bad)
        if not ok.all() or len(set(c[ok].tolist())) <= 1:
            k = np.unravel_index(int(np.argmin(ok)), c.shape)
            out[idx] = reason_short(rc[idx][k]) or short_reason(text[idx][k])
        else:
            split = any(len(set(row[m].tolist())) > 1 for row, m in zip(c, ok))
            out[idx] = reason_short(reason_value("replicates_disagree" if split else "starts_disagree"))
    return out


def level_edges(field, level, ex, ey) -> list[np.ndarray]:
    """The contour of ``field`` (v0 x eta) at ``level`` drawn on the cell edges: the edge
    between two neighbouring cells whose values lie on either side of the level (NaN
    cells have none), as segments ((x0, y0), (x1, y1)) in data coordinates (cell edges
    ``ex``, ``ey``).

    Each grid point is drawn as a cell, so the contour runs between the cells that
    bracket the level and never through a cell: an interpolated line (matplotlib's
    ``contour``) places the level between the points, linearly in eta and v0 although
    the axes are logarithmic, and can cut through a cell whose own value, and label,
    lies on the other side (the <q> = 3.81 line through a decided fluid cell)."""
    f = np.asarray(field, dtype=float)
    above = f >= level
    ok = np.isfinite(f)
    out = []
    n_v, n_e = f.shape
    for i in range(n_v):
        for j in range(n_e):
            if not ok[i, j]:
                continue
            if j + 1 < n_e and ok[i, j + 1] and above[i, j] != above[i, j + 1]:
                out.append(np.array([[ex[j + 1], ey[i]], [ex[j + 1], ey[i + 1]]]))
            if i + 1 < n_v and ok[i + 1, j] and above[i, j] != above[i + 1, j]:
                out.append(np.array([[ex[j], ey[i + 1]], [ex[j + 1], ey[i + 1]]]))
    return out


def _cell_fontsize(ax, n_cols) -> tuple[float, int]:
    """Font size and characters per line of text written inside one of ``n_cols`` cells."""
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72.0 / max(n_cols, 1)
    size = float(np.clip(width_pt / 9.0, 4.0, 6.0))
    return size, max(int(width_pt / (0.55 * size)), 6)


@styled
def _eta_v0_axes(ax, eta, v0, ex, ey, log_x: bool, log_y: bool) -> None:
    """Scales, grid ticks, limits (cell edges ``ex``, ``ey``) and labels of an eta x v0 map."""
    if log_x:
        ax.set_xscale("log")
    if log_y:
        ax.set_yscale("log")
    for axis, log, vals in ((ax.xaxis, log_x, eta), (ax.yaxis, log_y, v0)):
        if log:
            grid_ticks(axis, vals)
    ax.set_xlim(ex[0], ex[-1])
    ax.set_ylim(ey[0], ey[-1])
    ax.set_xlabel(ETA_LABEL)
    ax.set_ylabel(V0_LABEL)


def phase_diagram(ds, *, select=None, reasons: bool = True, ax=None):
    """Phase regions in the (eta, v0) plane, with the <q> = 3.81 and rho_d = 1/2 contours
    drawn on the cell edges between the points that bracket them (:func:`level_edges`).

    Each grid point is a cell coloured by its phase label (Okabe--Ito: solid blue,
    fluid green, soft fluid orange); ``undetermined`` points (or replicates that
    disagree) are grey and hatched, with the reason in short words
    (:func:`short_reason`) when ``reasons``; points without a label are white.  Axes are
    logarithmic where the grid is.  Replicates are reduced (labels must agree,
    observables averaged); other dimensions (N, ...) are taken at ``select`` or their
    last value.  The caption line names N, the run length and the quadrature.

    Parameters
    ----------
    ds : xarray.Dataset
        A phase-diagram dataset (:func:`fcsweep.results.aggregate.build_dataset`).
    select : dict, optional
        Values of the other dimensions (N, ...) to draw.
    reasons : bool
        Write each undetermined point's reason in its cell.
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    eta, v0 = ds["eta"].values.astype(float), ds["v0"].values.astype(float)
    words = phase_words(ds, ("v0", "eta"), select)
    log_x, log_y = log_axis(eta), log_axis(v0)
    ex, ey = cell_edges(eta, log_x), cell_edges(v0, log_y)
    own = ax is None
    fig, ax = own_axes(ax, (COLUMN, 3.3))
    order = ["solid", "fluid", "soft_fluid", "undetermined", "unknown"]
    idx = np.vectorize(lambda w: order.index(w) if w in order else order.index("unknown"))(words)
    cmap = ListedColormap([PHASE_COLORS[w][0] for w in order])
    ax.pcolormesh(ex, ey, idx, cmap=cmap, norm=BoundaryNorm(np.arange(len(order) + 1) - 0.5, len(order)),
                  edgecolors="w", linewidth=0.6)
    undetermined = list(zip(*np.nonzero(words == "undetermined")))
    for i, j in undetermined:
        ax.add_patch(Rectangle((ex[j], ey[i]), ex[j + 1] - ex[j], ey[i + 1] - ey[i], fill=False,
                               hatch="///", edgecolor="0.55", linewidth=0))
    handles = [Patch(facecolor=PHASE_COLORS[w][0], edgecolor="0.5", label=PHASE_COLORS[w][1],
                     hatch="///" if w == "undetermined" else None)
               for w in order if np.any(words == w)]
    if eta.size * v0.size >= 2:
        for var, level, style, label in (("q_mean", Q_STAR, "-", r"$\langle q\rangle = 3.81$"),
                                         ("rho_d", RHO_D_PERCOLATION, "--", r"$\rho_d = 1/2$")):
            if var not in ds:
                continue
            field = on_plane(ds, var, ("v0", "eta"), select).values
            edges = level_edges(field, level, ex, ey)
            if edges:
                lw = 2.6 if style == "-" else 1.1
                if style == "--":  # white under the dashes: seen inside the <q> line where they share an edge
                    ax.add_collection(LineCollection(edges, colors="w", linewidths=lw))
                ax.add_collection(LineCollection(edges, colors="k", linestyles=style, linewidths=lw,
                                                 gid=f"{var}_contour"))
                handles.append(plt.Line2D([], [], color="k", ls=style, lw=lw, label=label))
    _eta_v0_axes(ax, eta, v0, ex, ey, log_x, log_y)
    if reasons and undetermined:
        why = _point_reasons(ds, ("v0", "eta"), select)
        size, chars = _cell_fontsize(ax, len(eta))
        for i, j in undetermined:
            text = why[i, j]
            if text:
                ax.text(np.sqrt(ex[j] * ex[j + 1]) if log_x else 0.5 * (ex[j] + ex[j + 1]),
                        np.sqrt(ey[i] * ey[i + 1]) if log_y else 0.5 * (ey[i] + ey[i + 1]),
                        textwrap.fill(text, chars, break_long_words=False), ha="center", va="center",
                        fontsize=size, color="k", gid="reason", linespacing=1.0,
                        bbox={"facecolor": "w", "edgecolor": "none", "alpha": 0.75, "pad": 0.8})
    if own:
        ax.set_title(caption(ds, select, caption_chars(ax)), fontsize=CAPTION_SIZE, loc="left")
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.2), borderaxespad=0,
              ncols=3, columnspacing=1.0, handlelength=1.6)
    return fig


def _accepted(ds, keep, select) -> np.ndarray | None:
    """True where the phase label was decided (neither undetermined nor unknown); None
    for datasets without the ``phase`` variable."""
    if "phase" not in ds:
        return None
    words = phase_words(ds, keep, select)
    return (words != "undetermined") & (words != "unknown")


@styled
def d_eff_curves(ds, *, select=None, ax=None):
    """D_eff against eta, one curve per v0, with 1-sigma error bars where the dataset has
    ``D_eff_err`` and the solid threshold 1e-3; a log axis, symlog where some D_eff <= 0
    (fit noise in a solid).

    Values the label rule did not accept (phase undetermined or unknown at that point)
    are hollow markers, decided ones filled; a legend says so when both occur. Where the
    dataset has ``D_eff_cr``, the cage-relative D_eff on which the rule tests "solid" is
    drawn too (dashed, squares): a crystal's plain D_eff can stay above 1e-3 while its
    cages hold.

    Parameters
    ----------
    ds : xarray.Dataset
        A phase-diagram dataset.
    select : dict, optional
        Values of the other dimensions (N, ...) to draw.
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    D = on_plane(ds, "D_eff", ("v0", "eta"), select)
    err = error_of(ds, "D_eff", ("v0", "eta"), select)
    accepted = _accepted(ds, ("v0", "eta"), select)
    eta, v0 = D["eta"].values.astype(float), D["v0"].values
    own = ax is None
    fig, ax = own_axes(ax, (COLUMN, 2.7))
    cr = on_plane(ds, "D_eff_cr", ("v0", "eta"), select).values if "D_eff_cr" in ds else None
    cr_err = error_of(ds, "D_eff_cr", ("v0", "eta"), select) if cr is not None else None
    hollow_any = filled_any = False
    for k, col in enumerate(value_colors(len(v0))):
        y = D.values[k]
        ok = np.isfinite(y)
        if not ok.any():
            continue
        ax.errorbar(eta[ok], y[ok], yerr=None if err is None else err[k][ok], fmt="-", color=col,
                    capsize=2.0, lw=1.0)
        acc = np.ones_like(ok) if accepted is None else accepted[k]
        if (ok & acc).any():
            ax.plot(eta[ok & acc], y[ok & acc], "o", color=col, gid="accepted")
            filled_any = True
        if (ok & ~acc).any():
            ax.plot(eta[ok & ~acc], y[ok & ~acc], "o", mfc="w", mec=col, mew=1.0, gid="not_accepted")
            hollow_any = True
        if cr is not None and np.isfinite(cr[k]).any():
            c = np.isfinite(cr[k])
            ax.errorbar(eta[c], cr[k][c], yerr=None if cr_err is None else cr_err[k][c], fmt="s--", color=col,
                        ms=3.0, capsize=1.5, lw=0.8, gid="cage_relative")
    ax.axhline(D_EFF_SOLID, color="k", ls=":", lw=1.0)
    ax.text(0.99, D_EFF_SOLID, r"solid below $10^{-3}$", transform=ax.get_yaxis_transform(), fontsize=6.5,
            ha="right", va="top", zorder=1.5)
    vals = np.concatenate([D.values.ravel()] + ([] if cr is None else [cr.ravel()]))
    vals = vals[np.isfinite(vals)]
    if vals.size and (vals <= 0).any():  # fit noise makes a solid's D_eff <= 0: symlog keeps it
        ax.set_yscale("symlog", linthresh=1e-4, linscale=0.5)
    else:
        ax.set_yscale("log")
        lo, hi = ax.get_ylim()
        ax.set_ylim(min(lo, D_EFF_SOLID / 4), max(hi, 2 * D_EFF_SOLID))  # room for the threshold's words
        tidy_log(ax)
    eta_axis(ax, eta)
    ax.set_ylabel(r"$D_{\rm eff} = D_s / D_0$")
    marks = []
    if hollow_any:
        marks = [Line2D([], [], marker="o", ls="none", color="0.3", mfc="w", label="undetermined label")]
        if filled_any:
            marks.insert(0, Line2D([], [], marker="o", ls="none", color="0.3", label="label decided"))
    if cr is not None and np.isfinite(cr).any():
        marks.append(Line2D([], [], marker="s", ms=3.0, ls="--", lw=0.8, color="0.3",
                            label="cage-relative (solid test)"))
    if marks:
        ax.legend(handles=marks, loc="best", handletextpad=0.2)
    if own:
        ax.set_title(caption(ds, select, caption_chars(ax)), fontsize=CAPTION_SIZE, loc="left")
    value_colorbar(fig, ax, v0, V0_SYMBOL)
    return fig


#: Marker, colour and legend label of each summary label (:func:`summary_diagram`); KTHNY's
#: "liquid" is drawn and named "fluid", the word every other figure and label uses.
SUMMARY_STYLE = {"solid": ("h", OKABE_ITO["blue"], "solid"),
                 "hexatic": ("D", OKABE_ITO["sky"], "hexatic"),
                 "liquid": ("o", OKABE_ITO["green"], "fluid"),
                 "soft_fluid": ("s", OKABE_ITO["orange"], "soft fluid"),
                 "undetermined": ("o", "#DDDDDD", "undetermined"),
                 "unknown": ("x", "0.6", "not analysed")}


def summary_labels(ds, select=None) -> np.ndarray:
    """The summary label of every point of the (v0, eta) plane: the KTHNY label (solid,
    hexatic, liquid) where it is decided, with a liquid whose phase is soft fluid called
    ``soft_fluid``; the phase label (solid, fluid -> liquid, soft fluid) wherever the KTHNY
    label is not decided (undetermined or unknown: at N < 4096 it never is);
    ``undetermined`` where neither is decided and one is undetermined, else ``unknown``
    (``none`` where no run exists: an empty ``run_id``).  Needs ``kthny``."""
    kthny = phase_words(ds, ("v0", "eta"), select, var="kthny", default=KTHNY_FLAGS)
    phase = phase_words(ds, ("v0", "eta"), select) if "phase" in ds else np.full(kthny.shape, "unknown", object)
    out = np.full(kthny.shape, "unknown", dtype=object)
    for word in ("solid", "hexatic", "liquid", "undetermined"):
        out[kthny == word] = word
    out[(kthny == "liquid") & (phase == "soft_fluid")] = "soft_fluid"
    from_phase = (kthny == "unknown") | (kthny == "undetermined")
    out[from_phase & (phase == "solid")] = "solid"
    out[from_phase & (phase == "fluid")] = "liquid"
    out[from_phase & (phase == "soft_fluid")] = "soft_fluid"
    out[from_phase & (phase == "undetermined")] = "undetermined"
    if "run_id" in ds:  # grid points no run visited (holes of refined or joined grids)
        ids = reduce_to(ds["run_id"], ("v0", "eta"), select).values
        out[(out == "unknown") & (ids == "")] = "none"
    return out


@styled
def summary_diagram(ds, *, select=None, ax=None):
    """Summary phase diagram in the style of the paper's Fig. 4e: one symbol per grid
    point of the (eta, v0) plane naming its KTHNY label (solid hexagons, hexatic
    diamonds, fluid (KTHNY liquid) circles, soft-fluid squares; undetermined points hatched grey,
    :func:`summary_labels`; grid points without a run are left empty).  Needs the
    ``kthny`` variable.

    Parameters
    ----------
    ds : xarray.Dataset
        A phase-diagram dataset with ``kthny``.
    select : dict, optional
        Values of the other dimensions (N, ...) to draw.
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if "kthny" not in ds:
        raise ValueError("the dataset has no kthny label: aggregate it again with this version")
    eta, v0 = ds["eta"].values.astype(float), ds["v0"].values.astype(float)
    labels = summary_labels(ds, select)
    log_x, log_y = log_axis(eta), log_axis(v0)
    ex, ey = cell_edges(eta, log_x), cell_edges(v0, log_y)
    own = ax is None
    fig, ax = own_axes(ax, (COLUMN, 3.1))
    E, V = np.meshgrid(eta, v0)
    size = float(np.clip(1400.0 / max(len(eta), len(v0)) ** 2, 12.0, 90.0))
    handles = []
    for word, (marker, color, text) in SUMMARY_STYLE.items():
        here = labels == word
        if not here.any():
            continue
        hatch = "/////" if word == "undetermined" else None
        edge = "0.25" if word not in ("unknown",) else None
        area = size * {"h": 1.3, "D": 0.7, "s": 0.85}.get(marker, 1.0)  # equal visual weight
        ax.scatter(E[here], V[here], s=area, marker=marker, c=color, edgecolors=edge, linewidths=0.6,
                   hatch=hatch, label=text, gid=word, zorder=3)
        handles.append(word)
    _eta_v0_axes(ax, eta, v0, ex, ey, log_x, log_y)
    if own:
        ax.set_title(caption(ds, select, caption_chars(ax)), fontsize=CAPTION_SIZE, loc="left")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), borderaxespad=0, ncols=3, columnspacing=1.0,
              handletextpad=0.2, markerscale=min(1.0, 40.0 / size) ** 0.5)
    return fig
