"""Figures of a sweep and of one run, fit for a paper or a talk (matplotlib).

* drawing -- functions that take arrays or the phase-diagram :class:`xarray.Dataset`
  and return a :class:`matplotlib.figure.Figure` (:func:`phase_diagram`,
  :func:`d_eff_curves`, :func:`q_distributions`, :func:`largest_cluster`,
  :func:`cluster_sizes`, :func:`correlations`, :func:`msd_curves`,
  :func:`summary_diagram`, :func:`snapshot`).  Each takes ``ax=None`` (or ``axes=None``
  for the figures of several panels): given, it draws into those axes, else it makes a
  figure;
* files -- :func:`plot_sweep`, :func:`plot_dataset`, :func:`snapshot_run` and
  :func:`movie_run` write figure files; finding them is :mod:`fcsweep.analysis.results`.

Importing the module leaves matplotlib's backend alone (a notebook keeps its own); the
command line selects Agg.  Conventions: colour-blind-safe palettes (viridis for ordered
values, truncated before its pale yellow end; Okabe--Ito for categories); single-panel
figures one paper column wide (:data:`COLUMN` = 3.4 in), figures of several panels two
columns (:data:`DOUBLE_COLUMN` = 7.0 in), fonts legible at that size and on a slide; a
caption line with N, run length and quadrature; eta, v0 and t in model units
(:data:`ETA_LABEL`, :data:`V0_LABEL`, :data:`TIME_UNIT`); log axes where a swept grid is
logarithmic, symlog where a quantity changes sign.  Every drawing function accepts 1-D
grids and single points; contours that need a 2-D grid with values on both sides of the
level are skipped.  Datasets with the ``<name>_err`` variables and the ``undetermined``
phase code get error bars, hollow markers and hatched cells; older ones draw without.
"""

from __future__ import annotations

import functools
import json
import re
import textwrap
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from fcsweep.analysis.diffusion import D_EFF_SOLID
from fcsweep.analysis.phase import KTHNY_FLAGS, PHASE_FLAGS, RHO_D_PERCOLATION
from fcsweep.analysis.results import find_run, has_analysed_run, run_trajectory, sweep_dataset
from fcsweep.model.shape import Q_STAR

TAU_PERC = 187.0 / 91.0
#: Okabe & Ito (2008) colour-blind-safe palette.
OKABE_ITO = {"black": "#000000", "orange": "#E69F00", "sky": "#56B4E9", "green": "#009E73",
             "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00", "purple": "#CC79A7"}
#: Fill colour and legend label of each phase word (CF flag_meanings of ``phase``).
PHASE_COLORS = {"solid": (OKABE_ITO["blue"], "solid"), "fluid": (OKABE_ITO["green"], "fluid"),
                "soft_fluid": (OKABE_ITO["orange"], "soft fluid"),
                "undetermined": ("#BBBBBB", "undetermined"), "unknown": ("#FFFFFF", "not analysed")}
#: Width of a single-panel figure (one paper column) and of a figure of several panels, inches.
COLUMN, DOUBLE_COLUMN = 3.4, 7.0
#: Matplotlib settings of every figure: 7-8.5 pt, legible in a printed column at 300 dpi.
STYLE = {"font.size": 8, "axes.titlesize": 8, "axes.labelsize": 8.5, "legend.fontsize": 7,
         "xtick.labelsize": 7.5, "ytick.labelsize": 7.5, "lines.linewidth": 1.2, "lines.markersize": 3.5,
         "axes.linewidth": 0.7, "legend.frameon": False, "savefig.dpi": 300,
         "figure.constrained_layout.use": True}
#: Font size of caption lines.
CAPTION_SIZE = 6.5
#: Model units (docs/model.md): lengths R0, time R0/(mu F); eta is a line tension (force
#: F), v0 a speed (mu F).
TIME_UNIT = r"$R_0/(\mu F)$"
ETA_LABEL = r"membrane tension $\eta$ [$F$]"
V0_LABEL = r"self-propulsion $v_0$ [$\mu F$]"
ETA_SYMBOL, V0_SYMBOL = r"$\eta$ [$F$]", r"$v_0$ [$\mu F$]"


def _styled(fn):
    """Draw ``fn``'s figure with :data:`STYLE`."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with plt.rc_context(STYLE):
            return fn(*args, **kwargs)
    return wrapper


def save_figure(fig, stem, *, dpi: int = 300) -> list[Path]:
    """Save ``fig`` as ``<stem>.png`` (``dpi``) and ``<stem>.pdf``; close it; return the paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    out = []
    for ext in ("png", "pdf"):
        p = stem.with_suffix(f".{ext}")
        fig.savefig(p, dpi=dpi, bbox_inches="tight", pad_inches=0.03)  # legends below the axes stay in
        out.append(p)
    plt.close(fig)
    return out


# ------------------------------------------------------------------ dataset helpers

def _plane(ds, var, keep, select=None):
    """``ds[var]`` averaged over replicates (NaN-aware), other extra dims at ``select`` or
    their last value (largest N), keeping the dims ``keep`` in that order."""
    da = ds[var]
    if np.issubdtype(da.dtype, np.integer):
        da = da.where(da >= 0)
    if "replicate" in da.dims and "replicate" not in keep:
        da = da.mean("replicate", skipna=True) if da.sizes["replicate"] > 1 else da.isel(replicate=0)
    return _select(da, keep, select)


def _select(da, keep, select):
    select = dict(select or {})
    for d in list(da.dims):
        if d in keep:
            continue
        if d in select:
            da = da.sel({d: select[d]}, method="nearest") if da[d].dtype.kind in "fi" else da.sel({d: select[d]})
        else:
            da = da.isel({d: -1})
    return da.transpose(*keep)


def _err(ds, var, keep, select):
    """The 1-sigma error of ``var`` (``<var>_err``) on the same plane, or None; replicates
    are combined as the error of their mean."""
    name = f"{var}_err"
    if name not in ds:
        return None
    da = ds[name]
    if "replicate" in da.dims and "replicate" not in keep:
        n = np.isfinite(da).sum("replicate")
        da = np.sqrt((da ** 2).sum("replicate", skipna=True)) / n.where(n > 0)
    return _select(da, keep, select).values


def _flag_words(da, default=None) -> dict[int, str]:
    """Code -> word of a CF flag variable, from its attributes (else ``default``,
    :data:`PHASE_FLAGS` if not given)."""
    vals, words = da.attrs.get("flag_values"), da.attrs.get("flag_meanings")
    if vals is None or not words:
        return dict(PHASE_FLAGS if default is None else default)
    return {int(v): w for v, w in zip(np.atleast_1d(vals), str(words).split())}


def _phase_words(ds, keep, select, var="phase", default=None) -> np.ndarray:
    """Label word of every point of the plane (of ``var``, a CF flag variable);
    replicates that disagree are ``undetermined``, points without a label ``unknown``."""
    da = ds[var]
    words = _flag_words(da, default)
    if "replicate" in da.dims and "replicate" not in keep:
        da = da.where(da >= 0)
        lo, hi = da.min("replicate", skipna=True), da.max("replicate", skipna=True)
        da = lo.where((lo == hi) | lo.isnull(), -2)  # -2: replicates disagree; NaN: no label at all
    codes = _select(da, keep, select).values
    out = np.full(codes.shape, "unknown", dtype=object)
    for code, word in words.items():
        out[codes == code] = word
    out[codes == -2] = "undetermined"
    return out


def _is_log_grid(values) -> bool:
    """True for at least 3 positive values whose ratios are more nearly constant than
    their differences (a grid laid out in logarithmic steps)."""
    v = np.sort(np.asarray(values, dtype=float))
    if v.size < 3 or v[0] <= 0:
        return False
    dl, dv = np.diff(np.log(v)), np.diff(v)
    return np.std(dl) / np.mean(dl) < 0.5 * np.std(dv) / np.mean(dv)


def _log_axis(values) -> bool:
    """Log axis for a logarithmic grid, and for positive values whose linear cells
    would reach zero or below (two points a decade apart: eta 0.01 and 0.1)."""
    v = np.asarray(values, dtype=float)
    if _is_log_grid(v):
        return True
    return v.size >= 2 and bool(np.all(v > 0)) and _edges(v, False)[0] <= 0


def _edges(values, log: bool) -> np.ndarray:
    """Cell edges around grid values (geometric midpoints on a log grid)."""
    v = np.asarray(values, dtype=float)
    if log:
        lv = np.log(v)
        if v.size == 1:
            return np.exp(lv[0] + np.array([-0.25, 0.25]))
        mid = 0.5 * (lv[1:] + lv[:-1])
        return np.exp(np.concatenate([[2 * lv[0] - mid[0]], mid, [2 * lv[-1] - mid[-1]]]))
    if v.size == 1:
        h = 0.25 * abs(v[0]) or 0.5
        return v[0] + np.array([-h, h])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def _config(ds) -> dict:
    try:
        return json.loads(ds.attrs.get("config", "{}"))
    except (TypeError, ValueError):
        return {}


def _setting(ds, name, select, cfg):
    """Value of a model parameter for the plotted plane: the selected or last coordinate
    when it is swept, else the config's value."""
    if name in ds.coords and ds[name].ndim == 1 and name in ds.dims:
        if select and name in select:
            return select[name]
        return ds[name].values[-1]
    grid = cfg.get("grid", {})
    if name in grid and grid[name]:
        return grid[name][-1]
    return cfg.get("model", {}).get(name)


def caption(ds, select=None, width: int | None = None) -> str:
    """One line naming what a figure shows: N, run length, quadrature, modes/points,
    D_r and the number of replicates (from the dataset's config attribute); wrapped at
    ``width`` characters if given."""
    cfg = _config(ds)
    parts = []
    N = _setting(ds, "N", select, cfg)
    if N is not None:
        parts.append(f"N = {int(N)}")
    steps = cfg.get("run", {}).get("steps")
    dt = _setting(ds, "dt", select, cfg)
    if steps:
        length = f"{steps * dt:g} time units ({steps:,} steps)" if dt else f"{steps:,} steps"
        until = cfg.get("run", {}).get("until")
        parts.append(f"runs of up to {length}, stopped when settled" if until else f"runs of {length}")
    quad = _setting(ds, "quadrature", select, cfg)
    if quad:
        parts.append(f"{quad} quadrature")
    modes, k = _setting(ds, "modes", select, cfg), _setting(ds, "contour_points", select, cfg)
    if modes is not None and k is not None:
        parts.append(f"M = {modes}, K = {k}")
    dr = _setting(ds, "Dr", select, cfg)
    if dr is not None:
        parts.append(rf"$D_r$ = {dr:g}")
    if "replicate" in ds.dims and ds.sizes["replicate"] > 1:
        parts.append(f"{ds.sizes['replicate']} replicates")
    text = ", ".join(parts)
    return textwrap.fill(text, width, break_long_words=False) if width else text


def _colors(n):
    """``n`` ordered colours from viridis, stopping before its pale yellow end."""
    return plt.get_cmap("viridis")(np.linspace(0.0, 0.85, max(n, 1)))


def _value_colorbar(fig, axes, values, label):
    """A discrete colour bar naming the value of each curve's colour."""
    n = len(values)
    cmap = ListedColormap(_colors(n))
    sm = plt.cm.ScalarMappable(norm=BoundaryNorm(np.arange(n + 1) - 0.5, n), cmap=cmap)
    cb = fig.colorbar(sm, ax=axes, ticks=np.arange(n), aspect=30, pad=0.02)
    cb.ax.set_yticklabels([_grid_label(v) for v in values])
    cb.set_label(label)
    return cb


def _caption_chars(ax) -> int:
    """Characters of a caption line (at :data:`CAPTION_SIZE`) that fit over ``ax``."""
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72.0
    return max(int(width_pt / (0.55 * CAPTION_SIZE)), 30)


def _axes(ax, size):
    """``(figure, ax)``: the given Axes and its figure, or a new figure of ``size`` inches."""
    if ax is not None:
        return ax.figure, ax
    return plt.subplots(figsize=size)


def _panels(n, width=None, height=1.9, sharey=True):
    """A grid of ``n`` panels (at most 3 per row) with shared axes; spare axes removed.
    The figure is one column wide for one panel, two columns for more (``width``: of
    each panel, inches, instead)."""
    ncols = min(n, 3)
    nrows = -(-n // ncols)
    total = width * ncols + 0.9 if width else (COLUMN if ncols == 1 else DOUBLE_COLUMN)
    fig, axes = plt.subplots(nrows, ncols, figsize=(total, height * nrows + 0.5),
                             sharex=True, sharey=sharey, squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.remove()
    return fig, flat[:n]


def _grid_label(v) -> str:
    """A grid value in three digits (log-spaced grids give 0.0562341 and the like)."""
    return f"{v:.3g}"


def _grid_ticks(axis, values, most=None):
    """Ticks at the grid values of a log axis (decades alone rarely label a 0.01-0.1
    sweep), in three digits; past ``most`` values only every k-th one is labelled, so
    that refined grids do not print labels on top of each other (default: 6 on a y
    axis, one per half inch of a x axis)."""
    values = np.asarray(values, dtype=float)
    if most is None:
        width = axis.axes.get_position().width * axis.axes.figure.get_figwidth()
        most = max(3, int(width / 0.5)) if axis.axis_name == "x" else 6
    step = int(np.ceil(values.size / most))
    axis.set_ticks(values)
    axis.set_ticklabels([_grid_label(v) if i % step == 0 else "" for i, v in enumerate(values)])
    axis.set_minor_formatter(NullFormatter())


def _eta_axis(ax, eta):
    """The x axis of curves against eta: logarithmic where the grid is, labelled."""
    if _log_axis(eta):
        ax.set_xscale("log")
        _grid_ticks(ax.xaxis, eta)
    ax.set_xlabel(ETA_LABEL)


def _tidy_log(ax):
    """Log axes spanning under two decades get labelled 1-2-5 ticks (under one decade:
    1..9) in plain numbers, not a single 10^0 nor overlapping minor labels."""
    for axis, lim in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        if axis.get_scale() != "log":
            continue
        axis.set_minor_formatter(NullFormatter())
        lo, hi = sorted(lim)
        if lo > 0 and hi / lo < 100:
            subs = np.arange(1.0, 10.0) if hi / lo < 10 else (1.0, 2.0, 5.0)
            axis.set_major_locator(LogLocator(subs=subs))
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))


def _no_data(ax, text="no data"):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.3",
            bbox={"facecolor": "w", "edgecolor": "none", "alpha": 0.9})


# ------------------------------------------------------------------ sweep figures

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
    """The reason (``<label>_reason``) of every point of the plane; over replicates, the
    first replicate's whose label is not accepted (undetermined or unknown), or
    "replicates disagree" where accepted labels differ."""
    name = f"{label}_reason"
    codes = ds[label]
    shape = tuple(ds.sizes[d] for d in keep)
    if name not in ds:
        return np.full(shape, "", dtype=object)
    words = _flag_words(codes)
    bad = [c for c, w in words.items() if w in ("undetermined", "unknown")]
    if "replicate" not in ds[name].dims or "replicate" in keep:
        return _select(ds[name], keep, select).values.astype(object)
    text = _select(ds[name], tuple(keep) + ("replicate",), select).values
    code = _select(codes, tuple(keep) + ("replicate",), select).values
    out = np.full(shape, "", dtype=object)
    for idx in np.ndindex(*shape):
        c, t = code[idx], text[idx]
        accepted = [int(v) for v in c if int(v) not in bad]
        not_ok = [k for k, v in enumerate(c) if int(v) in bad]
        if not_ok:
            out[idx] = t[not_ok[0]]
        elif len(set(accepted)) > 1:
            out[idx] = "replicates disagree"
        else:
            out[idx] = t[0]
    return out


def _cell_fontsize(ax, n_cols) -> tuple[float, int]:
    """Font size and characters per line of text written inside one of ``n_cols`` cells."""
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72.0 / max(n_cols, 1)
    size = float(np.clip(width_pt / 9.0, 4.0, 6.0))
    return size, max(int(width_pt / (0.55 * size)), 6)


@_styled
def _eta_v0_axes(ax, eta, v0, ex, ey, log_x: bool, log_y: bool) -> None:
    """Scales, grid ticks, limits (cell edges ``ex``, ``ey``) and labels of an eta x v0 map."""
    if log_x:
        ax.set_xscale("log")
    if log_y:
        ax.set_yscale("log")
    for axis, log, vals in ((ax.xaxis, log_x, eta), (ax.yaxis, log_y, v0)):
        if log:
            _grid_ticks(axis, vals)
    ax.set_xlim(ex[0], ex[-1])
    ax.set_ylim(ey[0], ey[-1])
    ax.set_xlabel(ETA_LABEL)
    ax.set_ylabel(V0_LABEL)


def phase_diagram(ds, *, select=None, reasons: bool = True, ax=None):
    """Phase regions in the (eta, v0) plane, with the <q> = 3.81 and rho_d = 1/2 contours.

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
        A phase-diagram dataset (:func:`fcsweep.analysis.aggregate.build_dataset`).
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
    words = _phase_words(ds, ("v0", "eta"), select)
    log_x, log_y = _log_axis(eta), _log_axis(v0)
    ex, ey = _edges(eta, log_x), _edges(v0, log_y)
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 3.3))
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
    if len(eta) >= 2 and len(v0) >= 2:
        for var, level, style, label in (("q_mean", Q_STAR, "-", r"$\langle q\rangle = 3.81$"),
                                         ("rho_d", RHO_D_PERCOLATION, "--", r"$\rho_d = 1/2$")):
            if var not in ds:
                continue
            field = _plane(ds, var, ("v0", "eta"), select).values
            f = np.ma.masked_invalid(field)
            if f.count() >= 4 and np.nanmin(field) < level < np.nanmax(field):
                ax.contour(eta, v0, f, levels=[level], colors="k", linestyles=style, linewidths=1.5)
                handles.append(plt.Line2D([], [], color="k", ls=style, lw=1.5, label=label))
    _eta_v0_axes(ax, eta, v0, ex, ey, log_x, log_y)
    if reasons and undetermined:
        why = _point_reasons(ds, ("v0", "eta"), select)
        size, chars = _cell_fontsize(ax, len(eta))
        for i, j in undetermined:
            text = short_reason(why[i, j])
            if text:
                ax.text(np.sqrt(ex[j] * ex[j + 1]) if log_x else 0.5 * (ex[j] + ex[j + 1]),
                        np.sqrt(ey[i] * ey[i + 1]) if log_y else 0.5 * (ey[i] + ey[i + 1]),
                        textwrap.fill(text, chars, break_long_words=False), ha="center", va="center",
                        fontsize=size, color="k", gid="reason", linespacing=1.0,
                        bbox={"facecolor": "w", "edgecolor": "none", "alpha": 0.75, "pad": 0.8})
    if own:
        ax.set_title(caption(ds, select, _caption_chars(ax)), fontsize=CAPTION_SIZE, loc="left")
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.2), borderaxespad=0,
              ncols=3, columnspacing=1.0, handlelength=1.6)
    return fig


def _accepted(ds, keep, select) -> np.ndarray | None:
    """True where the phase label was decided (neither undetermined nor unknown); None
    for datasets without the ``phase`` variable."""
    if "phase" not in ds:
        return None
    words = _phase_words(ds, keep, select)
    return (words != "undetermined") & (words != "unknown")


@_styled
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
    D = _plane(ds, "D_eff", ("v0", "eta"), select)
    err = _err(ds, "D_eff", ("v0", "eta"), select)
    accepted = _accepted(ds, ("v0", "eta"), select)
    eta, v0 = D["eta"].values.astype(float), D["v0"].values
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 2.7))
    cr = _plane(ds, "D_eff_cr", ("v0", "eta"), select).values if "D_eff_cr" in ds else None
    cr_err = _err(ds, "D_eff_cr", ("v0", "eta"), select) if cr is not None else None
    hollow_any = filled_any = False
    for k, col in enumerate(_colors(len(v0))):
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
        _tidy_log(ax)
    _eta_axis(ax, eta)
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
        ax.set_title(caption(ds, select, _caption_chars(ax)), fontsize=CAPTION_SIZE, loc="left")
    _value_colorbar(fig, ax, v0, V0_SYMBOL)
    return fig


def _per_v0(ds, var, coord, select, draw, ylabel, xlabel, *, sharey=True, axes=None):
    """One panel per v0 of curves ``var(coord)`` coloured by eta; ``draw(ax, x, y, color)``
    draws one curve and returns True if it drew anything.  ``axes``: one Axes per v0 to
    draw into (else a new figure).  The eta colour bar is added only where a curve is."""
    v0s = ds["v0"].values
    etas = ds["eta"].values
    own = axes is None
    if own:
        fig, axes = _panels(len(v0s), sharey=sharey)
    else:
        axes = list(axes)
        if len(axes) != len(v0s):
            raise ValueError(f"{len(v0s)} Axes needed (one per v0), got {len(axes)}")
        fig = axes[0].figure
    cols = _colors(len(etas))
    drew_any = False
    for ax, v in zip(axes, v0s):
        sel = {**dict(select or {}), "v0": v}
        c = _plane(ds, var, ("eta", coord), sel)
        drew = False
        for k, e in enumerate(c["eta"].values):
            drew |= bool(draw(ax, c[coord].values, c.sel(eta=e).values, cols[k]))
        if not drew:
            _no_data(ax, "no defect clusters" if var == "cluster_size_distribution" else "no data")
        drew_any |= drew
        ax.set_title(rf"$v_0$ = {float(v):g} $\mu F$")
    for ax in axes:
        spec = ax.get_subplotspec()
        if spec is None or spec.is_last_row() or len(axes) <= 3:
            ax.set_xlabel(xlabel)
        if spec is None or spec.is_first_col():
            ax.set_ylabel(ylabel)
    if drew_any:
        _value_colorbar(fig, axes, etas, ETA_SYMBOL)
    else:  # empty panels: no scale to read
        for ax in axes:
            ax.tick_params(which="both", left=False, bottom=False, labelleft=False, labelbottom=False)
    if own:
        fig.suptitle(caption(ds, select), fontsize=CAPTION_SIZE)
    return fig, axes


@_styled
def q_distributions(ds, *, select=None, axes=None):
    """Shape-index distributions P(q), one panel per v0, one curve per eta, with q* = 3.81
    and the circle's 2 sqrt(pi) marked.  ``axes``: one Axes per v0 to draw into."""
    def draw(ax, x, y, col):
        ok = np.isfinite(y)
        if ok.any():
            ax.plot(x[ok], y[ok], color=col)
        return ok.any()

    fig, axes = _per_v0(ds, "q_hist", "q_bin", select, draw, "P(q)", "shape index q", axes=axes)
    for ax in axes:
        ax.axvline(Q_STAR, color="k", ls="--", lw=0.9)
        ax.axvline(2 * np.sqrt(np.pi), color="0.6", ls=":", lw=0.9)
    axes[0].text(Q_STAR, 0.97, " q* = 3.81", transform=axes[0].get_xaxis_transform(), va="top", fontsize=6.5)
    return fig


@_styled
def largest_cluster(ds, *, v0=None, select=None, ax=None):
    """Largest defect-cluster fraction against eta at one v0 (default: the largest), one
    curve per N, with error bars where ``largest_cluster_fraction_err`` exists.
    ``ax``: draw into this Axes (else a new figure one column wide)."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    p = _plane(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    err = _err(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 2.7))
    palette = [OKABE_ITO[c] for c in ("blue", "vermillion", "green", "orange", "purple", "sky", "black")]
    eta = p["eta"].values.astype(float)
    for k, N in enumerate(p["N"].values):
        y = p.values[k]
        ok = np.isfinite(y)
        ax.errorbar(eta[ok], y[ok], yerr=None if err is None else err[k][ok], fmt="o-",
                    color=palette[k % len(palette)], capsize=2.0, label=f"N = {int(N)}")
    _eta_axis(ax, eta)
    ax.set_ylabel(r"$P_{\max} = s_{\max}/N$")
    ax.set_ylim(-0.02, 1.02)
    head = rf"$v_0$ = {float(sel['v0']):g} $\mu F$"
    if own:
        cap = caption(ds, {k: v for k, v in sel.items() if k != "N"})
        head += ", " + cap.split(", ", 1)[-1]
    ax.set_title(textwrap.fill(head, _caption_chars(ax), break_long_words=False), fontsize=CAPTION_SIZE,
                 loc="left")
    ax.legend(loc="best")
    return fig


def log_binned(sizes, counts, per_decade=8):
    """Cluster-size density n(s) in logarithmic bins (counts per unit size, normalised
    by the total number of clusters).  Returns bin centres and densities (NaN-free)."""
    sizes = np.asarray(sizes, dtype=float)
    counts = np.nan_to_num(np.asarray(counts, dtype=float))
    total = counts.sum()
    if total <= 0 or sizes.size == 0:
        return np.zeros(0), np.zeros(0)
    edges = np.unique(np.floor(np.logspace(0, np.log10(sizes.max() + 1),
                                           int(per_decade * np.log10(sizes.max() + 1)) + 2)))
    edges = np.append(edges[edges <= sizes.max()], sizes.max() + 1)
    h, _ = np.histogram(sizes, bins=edges, weights=counts)
    centre = np.sqrt(edges[:-1] * (edges[1:] - 1).clip(min=edges[:-1]))
    dens = h / np.diff(edges) / total
    ok = dens > 0
    return centre[ok], dens[ok]


def _guide(ax, x, slope, label, style="k--", through=None):
    """A power-law guide ``~ x**slope`` over ``x`` that leaves the axis range to the data.

    ``through`` (x0, y0): a point on the guide; by default the guide runs at 0.6 times
    the lowest one above every positive data point (the data's upper envelope), moved
    up or down as far as needed to stay inside the data's y range, so that it lies next
    to the curves it is compared with.  It spans the data's x range at most.  Nothing
    is drawn on an Axes without data.
    """
    data = [ln for ln in ax.get_lines() if len(np.atleast_1d(ln.get_xdata())) > 0]
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x) & (x > 0)]
    if not data or x.size < 2:
        return None
    spans = [np.asarray(ln.get_xdata(), dtype=float) for ln in data]
    lo = min(np.nanmin(v[v > 0]) for v in spans if np.any(v > 0)) if any(np.any(v > 0) for v in spans) else x.min()
    hi = max(np.nanmax(v) for v in spans)
    x0 = np.array([max(x.min(), lo), min(x.max(), hi)])
    if not x0[1] > x0[0]:
        return None
    if through is None:
        top = []
        for ln in data:
            xd, yd = (np.asarray(v, dtype=float) for v in ln.get_data())
            ok = np.isfinite(xd) & np.isfinite(yd) & (xd > 0) & (yd > 0)
            if ok.any():
                top.append(np.max(yd[ok] / (xd[ok] / x0[0]) ** slope))
        y0 = 0.6 * max(top) if top else 1.0
        shape = (x0 / x0[0]) ** slope  # the guide over y0 at its two ends
        lo, hi = sorted(ax.get_ylim())
        if lo > 0 and y0 * shape.min() < lo:
            y0 = 1.05 * lo / shape.min()
        if y0 * shape.max() > hi:
            y0 = 0.95 * hi / shape.max()
        through = (x0[0], y0)
    xlim, ylim = ax.get_xlim(), ax.get_ylim()
    (line,) = ax.plot(x0, through[1] * (x0 / through[0]) ** slope, style, lw=1.0, label=label, gid="guide")
    ax.set_xlim(xlim)
    ax.set_ylim(ylim)
    return line


@_styled
def cluster_sizes(ds, *, select=None, axes=None):
    """Defect cluster-size densities n(s), one panel per v0, one curve per eta, with the
    s^(-187/91) percolation guide; a panel without defects says so (and without any
    defect cluster, no colour bar nor guide is drawn).  ``axes``: one Axes per v0."""
    smax = max(float(np.nanmax(ds["cluster_size"].values)), 10.0)

    def draw(ax, x, y, col):
        s, d = log_binned(x, y)
        if s.size:
            ax.loglog(s, d, "o-", ms=2.5, color=col)
        return s.size > 0

    fig, axes = _per_v0(ds, "cluster_size_distribution", "cluster_size", select, draw, "n(s)",
                        "cluster size s", axes=axes)
    s = np.array([1.0, smax])
    drawn = False
    for ax in axes:
        if ax.get_lines():
            drawn |= _guide(ax, s, -TAU_PERC, r"$s^{-187/91}$") is not None
    if drawn:
        next(ax for ax in axes if ax.get_lines()).legend(loc="lower left")
    return fig


@_styled
def correlations(ds, *, across="eta", at=None, select=None, axes=None):
    """G_r(dx, 0) - 1 (symlog: it oscillates about 0) and G6(r) (log-log) with the
    KTHNY -1/3 and -1/4 guides (drawn through the top of the data; the axis ranges are
    the data's).

    One curve per value of ``across`` ("eta" or "v0") with the other parameter fixed at
    ``at`` (default: its largest value): the paper's Fig. 4 shows both cuts, across v0
    at eta = 0.1 and across eta at v0 = 0.06.  ``axes``: two Axes to draw into (else a
    new figure two columns wide).
    """
    fixed = "v0" if across == "eta" else "eta"
    sel = dict(select or {})
    sel[fixed] = ds[fixed].values[-1] if at is None else at
    gr = _plane(ds, "Gr", (across, "dx"), sel)
    g6 = _plane(ds, "G6", (across, "r"), sel)
    values = gr[across].values
    label = ETA_SYMBOL if across == "eta" else V0_SYMBOL
    own = axes is None
    if own:
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(DOUBLE_COLUMN, 2.7))
    else:
        a1, a2 = axes
        fig = a1.figure
    for e, col in zip(values, _colors(len(values))):
        x, y = gr["dx"].values, gr.sel({across: e}).values - 1.0
        ok = np.isfinite(y) & (x > 0)
        if ok.any():
            a1.plot(x[ok], y[ok], "-", lw=1.0, color=col)
        r, y6 = g6["r"].values, g6.sel({across: e}).values
        ok6 = np.isfinite(y6) & (y6 > 0) & (r > 0)
        if ok6.any():
            a2.loglog(r[ok6], y6[ok6], "-", color=col)
    a1.set_xscale("log")
    a1.set_yscale("symlog", linthresh=1e-2, linscale=0.6)
    a2.set_xscale("log")
    a2.set_yscale("log")
    for ax, slope, lab, xs in ((a1, -1 / 3, r"$\propto\Delta x^{-1/3}$", gr["dx"].values),
                               (a2, -1 / 4, r"$\propto r^{-1/4}$", g6["r"].values)):
        xs = xs[np.isfinite(xs) & (xs > 0)]
        if _guide(ax, xs[xs >= min(1.0, xs.max())] if xs.size else xs, slope, lab) is not None:
            ax.legend(loc="best")
    a1.axhline(0, color="0.6", lw=0.7)
    a1.set_xlabel(r"$\Delta x / R_0$")
    a1.set_ylabel(r"$G_r(\Delta x, 0) - 1$")
    a2.set_xlabel(r"$r / R_0$")
    a2.set_ylabel(r"$G_6(r)$")
    fixed_label = rf"$v_0$ = {float(sel[fixed]):g} $\mu F$" if fixed == "v0" else rf"$\eta$ = {float(sel[fixed]):g} $F$"
    _tidy_log(a1)
    _tidy_log(a2)
    if a1.get_lines() or a2.get_lines():
        _value_colorbar(fig, [a1, a2], values, label)
    if own:
        fig.suptitle(f"{fixed_label};  " + caption(ds, select), fontsize=CAPTION_SIZE)
    else:
        a1.set_title(fixed_label, loc="left")
    return fig


@_styled
def msd_curves(ds, *, v0=None, select=None, ax=None):
    """MSD against lag time, one curve per eta at one v0 (default: the largest), log-log,
    with the ballistic (slope 2) and diffusive (slope 1) guides.  ``ax``: draw into this
    Axes (else a new figure one column wide)."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    m = _plane(ds, "msd", ("eta", "lag_time"), sel)
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 2.7))
    t = m["lag_time"].values
    etas = m["eta"].values
    first = []
    for e, col in zip(etas, _colors(len(etas))):
        y = m.sel(eta=e).values
        ok = np.isfinite(y) & (y > 0) & (t > 0)
        if ok.any():
            ax.loglog(t[ok], y[ok], color=col)
            first.append(y[ok][0])
    tp = t[np.isfinite(t) & (t > 0)]
    if tp.size >= 2 and first:
        tt = np.array([tp.min(), tp.max()])
        y0 = 0.3 * min(first)  # guides start below the curves
        ax.loglog(tt, y0 * (tt / tt[0]) ** 2, "k:", lw=1, label=r"$\propto t^2$ (ballistic)")
        ax.loglog(tt, y0 * (tt / tt[0]), "k--", lw=1, label=r"$\propto t$ (diffusive)")
        ax.legend(loc="upper left")
    _tidy_log(ax)
    ax.set_xlabel(f"lag time t [{TIME_UNIT}]")
    ax.set_ylabel(r"MSD / $R_0^2$")
    head = rf"$v_0$ = {float(sel['v0']):g} $\mu F$"
    if own:
        head += ", " + caption(ds, select)
    ax.set_title(textwrap.fill(head, _caption_chars(ax), break_long_words=False), fontsize=CAPTION_SIZE,
                 loc="left")
    if first:
        _value_colorbar(fig, ax, etas, ETA_SYMBOL)
    return fig


#: Codes of the ``kthny`` label, used where the dataset's variable lacks CF flag attributes.
#: Marker, colour and legend label of each summary label (:func:`summary_diagram`).
SUMMARY_STYLE = {"solid": ("h", OKABE_ITO["blue"], "solid"),
                 "hexatic": ("D", OKABE_ITO["sky"], "hexatic"),
                 "liquid": ("o", OKABE_ITO["green"], "liquid"),
                 "soft_fluid": ("s", OKABE_ITO["orange"], "soft fluid"),
                 "undetermined": ("o", "#DDDDDD", "undetermined"),
                 "unknown": ("x", "0.6", "not analysed")}


def summary_labels(ds, select=None) -> np.ndarray:
    """The summary label of every point of the (v0, eta) plane: the KTHNY label (solid,
    hexatic, liquid) where it is decided, with a liquid whose phase is soft fluid called
    ``soft_fluid``; the phase label (solid, fluid -> liquid, soft fluid) where the KTHNY
    label is unknown; ``undetermined`` or ``unknown`` otherwise.  Needs ``kthny``."""
    kthny = _phase_words(ds, ("v0", "eta"), select, var="kthny", default=KTHNY_FLAGS)
    phase = _phase_words(ds, ("v0", "eta"), select) if "phase" in ds else np.full(kthny.shape, "unknown", object)
    out = np.full(kthny.shape, "unknown", dtype=object)
    for word in ("solid", "hexatic", "liquid", "undetermined"):
        out[kthny == word] = word
    out[(kthny == "liquid") & (phase == "soft_fluid")] = "soft_fluid"
    from_phase = kthny == "unknown"
    out[from_phase & (phase == "solid")] = "solid"
    out[from_phase & (phase == "fluid")] = "liquid"
    out[from_phase & (phase == "soft_fluid")] = "soft_fluid"
    out[from_phase & (phase == "undetermined")] = "undetermined"
    return out


@_styled
def summary_diagram(ds, *, select=None, ax=None):
    """Summary phase diagram in the style of the paper's Fig. 4e: one symbol per grid
    point of the (eta, v0) plane naming its KTHNY label (solid hexagons, hexatic
    diamonds, liquid circles, soft-fluid squares; undetermined points hatched grey,
    :func:`summary_labels`).  Needs the ``kthny`` variable.

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
    log_x, log_y = _log_axis(eta), _log_axis(v0)
    ex, ey = _edges(eta, log_x), _edges(v0, log_y)
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 3.1))
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
        ax.set_title(caption(ds, select, _caption_chars(ax)), fontsize=CAPTION_SIZE, loc="left")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), borderaxespad=0, ncols=3, columnspacing=1.0,
              handletextpad=0.2, markerscale=min(1.0, 40.0 / size) ** 0.5)
    return fig


# ------------------------------------------------------------------ one frame

def cell_polygons(pos, theta, a, b, box, R0=1.0, points=48):
    """Contours of all cells as polygons, with periodic copies of cells that cross the box.

    Returns
    -------
    polys : list of ndarray (points, 2)
    owner : ndarray of int
        Cell index of each polygon.
    """
    from fcsweep.model.shape import radius

    pos = np.asarray(pos, dtype=float)
    N = pos.shape[0]
    phi = 2 * np.pi * np.arange(points) / points
    if a is None or np.shape(a)[-1] == 0:
        R = np.full((N, points), R0)
    else:
        R, _ = radius(phi, a, b, R0)
        R = np.atleast_2d(R)
    ang = np.asarray(theta, dtype=float)[:, None] + phi[None, :]
    xy = pos[:, None, :] + R[..., None] * np.stack([np.cos(ang), np.sin(ang)], -1)
    polys, owner = [], []
    box = np.asarray(box, dtype=float)
    for i in range(N):
        lo, hi = xy[i].min(0), xy[i].max(0)
        for sx in (-1, 0, 1):
            for sy in (-1, 0, 1):
                s = np.array([sx, sy]) * box
                if np.all(hi + s > 0) and np.all(lo + s < box):
                    polys.append(xy[i] + s)
                    owner.append(i)
    return polys, np.asarray(owner, dtype=np.int64)


#: Colour scale of q in snapshots and movies: from the circle to well above q*.
Q_NORM = Normalize(vmin=2 * np.sqrt(np.pi), vmax=4.3)


#: Width of a movie frame (a slide-size figure), inches, and its fonts (larger: a
#: slide is seen from further away than a printed column).
SLIDE = 6.4
SLIDE_STYLE = {**STYLE, "font.size": 11, "axes.titlesize": 11, "axes.labelsize": 12, "legend.fontsize": 10,
               "xtick.labelsize": 10.5, "ytick.labelsize": 10.5}
#: Movie frames are a whole number of these pixel blocks in each direction (the H.264
#: macro block: other sizes make imageio-ffmpeg rescale and warn).
MACRO_BLOCK = 16


class FrameArtist:
    """A figure of one frame that can be redrawn with the next frame (for movies).

    Cells are filled by their shape index q (viridis, from the circle's 2 sqrt(pi) to
    4.3) and outlined in white, so that touching cells of equal q stay apart; defect
    cells (Voronoi neighbours != 6) are outlined in vermillion with a dot at the centroid.

    Parameters
    ----------
    box : array_like (2,)
        Box lengths in R0.
    width : float
        Figure width, inches (default one paper column; :data:`SLIDE` for movies).
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes instead of a new figure.
    dpi : int, optional
        Make an off-screen figure (Agg, not registered with pyplot) of exactly this
        resolution whose pixel sizes are multiples of :data:`MACRO_BLOCK` (movie frames).
    style : dict, optional
        Matplotlib settings (default :data:`STYLE`; :data:`SLIDE_STYLE` for movies).
    """

    def __init__(self, box, *, width=COLUMN, ax=None, dpi=None, style=None):
        self.box = np.asarray(box, dtype=float)
        style = STYLE if style is None else style
        self.title_size = 0.85 * float(style.get("axes.titlesize", 8))
        with plt.rc_context(style):
            size = (width, (width - 1.0) * self.box[1] / self.box[0] + 0.8)
            if ax is not None:
                self.fig, self.ax = ax.figure, ax
            elif dpi is not None:
                from matplotlib.backends.backend_agg import FigureCanvasAgg
                from matplotlib.figure import Figure

                px = [MACRO_BLOCK * int(np.ceil(v * dpi / MACRO_BLOCK)) for v in size]
                self.fig = Figure(figsize=(px[0] / dpi, px[1] / dpi), dpi=dpi, layout="constrained")
                FigureCanvasAgg(self.fig)
                self.ax = self.fig.add_subplot()
            else:
                self.fig, self.ax = plt.subplots(figsize=size)
            self.coll = PolyCollection([], cmap="viridis", norm=Q_NORM)
            self.ax.add_collection(self.coll)
            (self.dots,) = self.ax.plot([], [], "o", color=OKABE_ITO["vermillion"], ms=2.0)
            cb = self.fig.colorbar(self.coll, ax=self.ax, shrink=0.85, pad=0.02, aspect=30)
            cb.set_label("shape index q")
            cb.ax.axhline(Q_STAR, color="w", lw=1.2)
            self.ax.set_xlim(0, self.box[0])
            self.ax.set_ylim(0, self.box[1])
            self.ax.set_aspect("equal")
            self.ax.set_xlabel(r"$x / R_0$")
            self.ax.set_ylabel(r"$y / R_0$")

    def _cell_points(self) -> float:
        """Diameter of a cell (2 R0) on the page, points."""
        return 2.0 * self.ax.get_position().width * self.fig.get_figwidth() * 72.0 / self.box[0]

    def draw(self, pos, theta, a, b, q, defect, title=""):
        """Replace the drawn frame; returns the figure."""
        polys, owner = cell_polygons(pos, theta, a, b, self.box)
        q = np.asarray(q, dtype=float)
        defect = np.asarray(defect, dtype=bool)
        d = self._cell_points()
        lw = float(np.clip(0.05 * d, 0.15, 0.8))  # outlines stay thin next to small cells
        self.coll.set_verts(polys)
        self.coll.set_array(q[owner])
        self.coll.set_edgecolor(np.where(defect[owner, None], [[0.835, 0.369, 0.0, 1.0]], [[1.0, 1.0, 1.0, 0.9]]))
        self.coll.set_linewidth(np.where(defect[owner], 2.5 * lw, lw))
        p = np.asarray(pos)
        self.dots.set_data(p[defect, 0], p[defect, 1])
        self.dots.set_markersize(float(np.clip(0.2 * d, 1.0, 3.0)))
        self.ax.set_title(title or f"N = {len(p)}, defect fraction {defect.mean():.2f}", fontsize=self.title_size,
                          loc="left")
        return self.fig

    def rgb(self) -> np.ndarray:
        """The drawn frame as an (H, W, 3) uint8 array."""
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()


def snapshot(pos, theta, a, b, box, q, defect, *, R0=1.0, title="", ax=None):
    """One frame: every cell's contour filled by its shape index q, defect cells
    (Voronoi neighbours != 6) outlined with a dot at the centroid.

    Parameters
    ----------
    pos, theta, a, b : ndarray
        Centres (in R0), polarity angles and Fourier shape modes of the cells.
    box : array_like (2,)
        Box lengths in R0.
    q, defect : ndarray
        Shape index and defect flag of every cell.
    title : str
        Title (default: N and the defect fraction).
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    art = FrameArtist(box, ax=ax)
    return art.draw(pos, theta, a, b, q, defect, title)


# ------------------------------------------------------------------ files -> figures

def _frame(traj, k):
    """(pos, theta, a, b, q, defect) of frame ``k``, lengths in R0."""
    from fcsweep.analysis import shapes, voronoi

    R0 = float(traj.params.get("R0", 1.0))
    pos = traj.read("position", [k])[0] / R0
    box = traj.box / R0
    theta = traj.read("theta", [k])[0] if "theta" in traj.fields else np.zeros(len(pos))
    if "shape_a" in traj.fields and "shape_b" in traj.fields:
        a, b = traj.read("shape_a", [k])[0], traj.read("shape_b", [k])[0]
    else:
        a = b = np.zeros((len(pos), 0))
    q = shapes.shape_indices(a, b)
    defect = voronoi.defect_mask(voronoi.voronoi_neighbors(pos, box).n_sides)
    return pos, theta, a, b, q, defect


def _frame_title(traj, k, defect) -> str:
    """Two lines: the run and its parameters, then the time and the defect fraction (model units)."""
    p = traj.params

    def num(name):
        v = p.get(name, "?")
        return f"{float(v):g}" if isinstance(v, (int, float, np.number)) else str(v)

    return (rf"run {p.get('run_id', '')}:  $\eta$ = {num('eta')} $F$,  $v_0$ = {num('v0')} $\mu F$" "\n"
            rf"t = {traj.time[k]:g} {TIME_UNIT},  $\rho_d$ = {np.mean(defect):.2f}")


def snapshot_run(traj_path, frame=-1, stem=None) -> list[Path]:
    """Draw one frame of a trajectory (cells coloured by q, defects marked)."""
    from fcsweep.analysis.trajectory import open_trajectory

    traj = open_trajectory(traj_path)
    k = int(frame) % traj.n_frames
    pos, theta, a, b, q, defect = _frame(traj, k)
    fig = FrameArtist(traj.box / float(traj.params.get("R0", 1.0))).draw(
        pos, theta, a, b, q, defect, _frame_title(traj, k, defect))
    stem = stem or Path(traj_path).with_name(f"snapshot_frame{k}")
    return save_figure(fig, stem)


def movie_run(traj_path, out=None, *, fps=10, every=1, dpi=120, progress=True) -> Path:
    """MP4 movie of a trajectory: contours coloured by q, defects marked, one frame per
    ``every`` recorded frames (H.264 via imageio-ffmpeg), slide-size frames
    (:data:`SLIDE` inches wide) whose pixel sizes are multiples of 16.

    Parameters
    ----------
    traj_path : path-like
        A ``trajectory.h5``.
    out : path-like, optional
        Output file (default ``movie.mp4`` beside the trajectory).
    fps : int
        Frames per second of the movie.
    every : int
        Stride over the recorded frames.
    dpi : int
        Resolution of the rendered frames.
    progress : bool
        Show a progress bar (tqdm) on stderr.

    Raises
    ------
    ImportError
        If imageio / imageio-ffmpeg are missing (``pip install 'fcsweep[movie]'``).
    """
    try:
        import imageio.v2 as imageio
        import imageio_ffmpeg  # noqa: F401 - the writer backend
    except ImportError as exc:
        raise ImportError("fcsweep movie needs imageio and imageio-ffmpeg: "
                          "pip install 'fcsweep[movie]'") from exc
    from tqdm.auto import tqdm

    from fcsweep.analysis.trajectory import open_trajectory

    traj = open_trajectory(traj_path)
    out = Path(out) if out is not None else Path(traj_path).with_name("movie.mp4")
    out.parent.mkdir(parents=True, exist_ok=True)
    frames = range(0, traj.n_frames, max(int(every), 1))
    # frames are whole macro blocks (no rescaling by ffmpeg); yuv420p plays everywhere (QuickTime, browsers)
    art = FrameArtist(traj.box / float(traj.params.get("R0", 1.0)), width=SLIDE, dpi=dpi, style=SLIDE_STYLE)
    tmp = out.with_name(f".{out.stem}.partial{out.suffix}")
    try:
        with imageio.get_writer(tmp, fps=fps, codec="libx264", quality=8, macro_block_size=MACRO_BLOCK,
                                pixelformat="yuv420p", ffmpeg_log_level="error") as writer:
            for k in tqdm(frames, desc="movie", unit="frame", disable=not progress):
                pos, theta, a, b, q, defect = _frame(traj, k)
                art.draw(pos, theta, a, b, q, defect, _frame_title(traj, k, defect))
                writer.append_data(art.rgb())
        tmp.replace(out)
    finally:
        if tmp.exists():
            tmp.unlink()
    return out


#: Figure files of a sweep: name -> drawing function of the phase-diagram dataset.
SWEEP_FIGURES = {
    "phase_diagram": phase_diagram,
    "d_eff": d_eff_curves,
    "q_distributions": q_distributions,
    "largest_cluster": largest_cluster,
    "cluster_sizes": cluster_sizes,
    "correlations": correlations,
    "correlations_across_v0": lambda d: correlations(d, across="v0"),
    "msd": msd_curves,
}


#: Figures drawn only when the dataset has a variable: name -> (variable, drawing function).
OPTIONAL_FIGURES = {"summary": ("kthny", summary_diagram)}


def plot_dataset(ds, outdir) -> list[Path]:
    """All sweep figures of a phase-diagram dataset into ``outdir`` (those of
    :data:`OPTIONAL_FIGURES` where the dataset has their variable, those of
    :data:`FSS_FIGURES` where it has two or more N)."""
    outdir = Path(outdir)
    out = []
    for name, fn in SWEEP_FIGURES.items():
        out += save_figure(fn(ds), outdir / name)
    for name, (var, fn) in OPTIONAL_FIGURES.items():
        if var in ds:
            out += save_figure(fn(ds), outdir / name)
    if ds.sizes.get("N", 1) >= 2:
        for name, fn in FSS_FIGURES.items():
            out += save_figure(fn(ds), outdir / name)
    return out


class NothingToPlot(RuntimeError):
    """The sweep has no analysed run, so every figure would be blank."""


def plot_sweep(config, *, run=None, frame=-1, outdir=None) -> list[Path]:
    """Sweep figures (aggregating first if needed, :func:`fcsweep.analysis.results.sweep_dataset`),
    or the snapshot of run ``run``.

    Raises
    ------
    NothingToPlot
        When no run of the sweep is analysed (nothing is written).
    """
    outdir = Path(outdir) if outdir is not None else Path(config.output) / "figures"
    if run is not None:
        spec = find_run(config, run)
        return snapshot_run(run_trajectory(config, run), frame, outdir / f"snapshot_{spec.run_id}_frame{frame}")
    ds = sweep_dataset(config)
    if not has_analysed_run(ds):
        raise NothingToPlot(f"no analysed run in {config.output}: run `fcsweep analyze` first")
    return plot_dataset(ds, outdir)


# ------------------------------------------------------------------ finite-size scaling

#: Marker of each N in the finite-size figures (with the Okabe--Ito colours of :func:`largest_cluster`).
FSS_MARKERS = ("o", "s", "^", "D", "v", "P", "X")
FSS_PALETTE = tuple(OKABE_ITO[c] for c in ("blue", "vermillion", "green", "orange", "purple", "sky", "black"))


def _fss_slice(ds, select):
    """``(rho_d, P_max, P_max error, N, selection)`` of every (N, eta) point of one v0
    slice (default: the largest v0): the replicate means where the dataset has them."""
    sel = dict(select or {})
    sel.setdefault("v0", ds["v0"].values[-1])
    sel.pop("N", None)
    keep = ("N", "eta")
    if "rho_d_rmean" in ds and "largest_cluster_fraction_rmean" in ds:
        rho = _select(ds["rho_d_rmean"], keep, sel).values
        p = _select(ds["largest_cluster_fraction_rmean"], keep, sel).values
        e = _select(ds["largest_cluster_fraction_rmean_err"], keep, sel).values
    else:
        rho = _plane(ds, "rho_d", keep, sel).values
        p = _plane(ds, "largest_cluster_fraction", keep, sel).values
        e = _err(ds, "largest_cluster_fraction", keep, sel)
        e = np.full(p.shape, np.nan) if e is None else e
    N = np.broadcast_to(ds["N"].values.astype(float)[:, None], p.shape)
    return rho, p, e, N, sel


def _fss_head(ds, sel, own, ax, text):
    head = rf"$v_0$ = {float(sel['v0']):g} $\mu F$"
    if text:
        head += f"; {text}"
    if own:  # the caption without its N: every N is drawn
        rest = [c for c in caption(ds, sel).split(", ") if c and not c.startswith("N = ")]
        if rest:
            head += ", " + ", ".join(rest)
    ax.set_title(textwrap.fill(head, _caption_chars(ax), break_long_words=False), fontsize=CAPTION_SIZE,
                 loc="left")


@_styled
def fss_collapse_figure(ds, *, select=None, exponents="fit", ax=None):
    """Finite-size collapse of the largest defect cluster (the paper's Fig. 3c):
    ``P_max L^(beta/nu)`` against ``(rho_d - rho_c) L^(1/nu)``, ``L = sqrt(N)``, one
    marker and colour per N, with 1-sigma error bars.

    Parameters
    ----------
    ds : xarray.Dataset
        A phase-diagram dataset with two or more N.
    select : dict, optional
        The v0 (default: the largest) and other swept values of the slice drawn.
    exponents : {"fit", "paper"}
        ``"fit"``: rho_c, nu and beta of the dataset's ``fss_*`` variables (fitted here
        when the dataset lacks them); ``"paper"``: the exponents of 2-D percolation,
        nu = 4/3 and beta = 5/36, with rho_c fitted for them
        (:func:`fcsweep.analysis.percolation.fss_collapse` with ``fixed``).
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from fcsweep.analysis.percolation import BETA_2D, NU_2D, fss_collapse, fss_scaled

    if exponents not in ("fit", "paper"):
        raise ValueError(f"exponents must be 'fit' or 'paper', got {exponents!r}")
    rho, p, e, N, sel = _fss_slice(ds, select)
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 2.7))
    ok = np.isfinite(rho) & np.isfinite(p)
    fit, why = None, ""
    if exponents == "fit" and "fss_rho_c" in ds:
        vals = {k: float(_select(ds[f"fss_{k}"], (), sel).values)
                for k in ("rho_c", "rho_c_err", "nu", "nu_err", "beta", "beta_err")}
        if np.isfinite(vals["rho_c"]):
            fit = vals
        else:
            why = str(_select(ds["fss_reason"], (), sel).values) if "fss_reason" in ds else "no fit"
    elif np.unique(N[ok]).size >= 2:
        fixed = {"nu": NU_2D, "beta": BETA_2D} if exponents == "paper" else None
        r = fss_collapse(rho[ok], p[ok], N[ok], np.where(np.isfinite(e[ok]), e[ok], 0.0), fixed=fixed,
                         n_bootstrap=0)
        fit = dict(r) if np.isfinite(r.rho_c) else None
        why = r.reason
    else:
        why = "fewer than two N with data"
    if fit is None:
        _no_data(ax, textwrap.fill(f"no collapse: {why}", 40))
        _fss_head(ds, sel, own, ax, "")
        return fig
    for k, n in enumerate(ds["N"].values):
        m = ok[k]
        if not m.any():
            continue
        x, y = fss_scaled(rho[k][m], p[k][m], float(n), fit["rho_c"], fit["nu"], fit["beta"])
        yerr = e[k][m] * float(n) ** (0.5 * fit["beta"] / fit["nu"])
        order = np.argsort(x)
        ax.errorbar(x[order], y[order], yerr=None if not np.isfinite(yerr).any() else yerr[order],
                    fmt=FSS_MARKERS[k % len(FSS_MARKERS)], ls="none", ms=3.5, capsize=1.5, mfc="none",
                    color=FSS_PALETTE[k % len(FSS_PALETTE)], label=f"N = {int(n)}")
    ax.axvline(0, color="0.6", lw=0.7, ls=":")
    ax.set_xlabel(r"$(\rho_d - \rho_c)\,L^{1/\nu}$,  $L = \sqrt{N}$")
    ax.set_ylabel(r"$P_{\max}\,L^{\beta/\nu}$")

    def pm(name, digits):
        err = fit.get(f"{name}_err", np.nan)
        v = f"{fit[name]:.{digits}f}"
        return v + (rf" $\pm$ {err:.{digits}f}" if np.isfinite(err) and err > 0 else "")

    if exponents == "paper":
        text = rf"$\rho_c$ = {pm('rho_c', 3)}, $\nu$ = 4/3, $\beta$ = 5/36 (2-D percolation)"
    else:
        text = rf"$\rho_c$ = {pm('rho_c', 3)}, $\nu$ = {pm('nu', 2)}, $\beta$ = {pm('beta', 3)} (fit)"
    _fss_head(ds, sel, own, ax, text)
    ax.legend(loc="upper left")
    return fig


@_styled
def largest_cluster_unscaled(ds, *, select=None, ax=None):
    """Largest defect-cluster fraction P_max against the defect fraction rho_d, one
    marker and colour per N, with 1-sigma error bars (the paper's Fig. S7: the data of
    the collapse, :func:`fss_collapse_figure`, before scaling); the 2-D percolation
    threshold rho_d = 1/2 is marked.

    Parameters
    ----------
    ds : xarray.Dataset
        A phase-diagram dataset.
    select : dict, optional
        The v0 (default: the largest) and other swept values of the slice drawn.
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    rho, p, e, N, sel = _fss_slice(ds, select)
    own = ax is None
    fig, ax = _axes(ax, (COLUMN, 2.7))
    ok = np.isfinite(rho) & np.isfinite(p)
    for k, n in enumerate(ds["N"].values):
        m = ok[k]
        if not m.any():
            continue
        order = np.argsort(rho[k][m])
        yerr = e[k][m][order]
        ax.errorbar(rho[k][m][order], p[k][m][order], yerr=yerr if np.isfinite(yerr).any() else None,
                    fmt=FSS_MARKERS[k % len(FSS_MARKERS)] + "-", ms=3.5, capsize=1.5, mfc="none", lw=0.8,
                    color=FSS_PALETTE[k % len(FSS_PALETTE)], label=f"N = {int(n)}")
    if not ok.any():
        _no_data(ax)
    ax.axvline(RHO_D_PERCOLATION, color="0.6", lw=0.7, ls=":")
    ax.set_xlabel(r"defect fraction $\rho_d$")
    ax.set_ylabel(r"$P_{\max} = s_{\max}/N$")
    ax.set_ylim(-0.02, 1.02)
    _fss_head(ds, sel, own, ax, "")
    if ok.any():
        ax.legend(loc="upper left")
    return fig


#: Figures drawn when the dataset has two or more N: name -> drawing function.
FSS_FIGURES = {"fss_collapse": fss_collapse_figure, "largest_cluster_unscaled": largest_cluster_unscaled}
