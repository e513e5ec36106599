"""Figures of a sweep and of one run, fit for a paper or a talk (matplotlib, Agg).

Two layers in one module:

* drawing -- functions that take arrays or the phase-diagram :class:`xarray.Dataset`
  and return a :class:`matplotlib.figure.Figure` (:func:`phase_diagram`,
  :func:`d_eff_curves`, :func:`q_distributions`, :func:`largest_cluster`,
  :func:`cluster_sizes`, :func:`correlations`, :func:`msd_curves`, :func:`snapshot`);
* files -- :func:`plot_sweep`, :func:`plot_dataset`, :func:`snapshot_run` and
  :func:`movie_run` read ``phase_diagram.nc`` or a trajectory and write figure files.

Conventions: colour-blind-safe palettes (viridis for ordered values, truncated before
its pale yellow end; Okabe--Ito for categories), fonts sized for a 300-dpi PNG and for a
slide, a caption line with N, run length and quadrature, log axes where a swept grid is
logarithmic, symlog where a quantity changes sign.  Every drawing function accepts 1-D
grids and single points; contours that need a 2-D grid with values on both sides of
the level are skipped.  Datasets with the ``<name>_err`` variables and the
``undetermined`` phase code get error bars and hatched cells; older ones draw without.
"""

from __future__ import annotations

import functools
import textwrap
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize  # noqa: E402
from matplotlib.patches import Patch, Rectangle  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

from fcsweep.analysis.diffusion import D_EFF_SOLID  # noqa: E402
from fcsweep.analysis.phase import PHASE_FLAGS, RHO_D_PERCOLATION  # noqa: E402
from fcsweep.model.shape import Q_STAR  # noqa: E402

TAU_PERC = 187.0 / 91.0
#: Okabe & Ito (2008) colour-blind-safe palette.
OKABE_ITO = {"black": "#000000", "orange": "#E69F00", "sky": "#56B4E9", "green": "#009E73",
             "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00", "purple": "#CC79A7"}
#: Fill colour and legend label of each phase word (CF flag_meanings of ``phase``).
PHASE_COLORS = {"solid": (OKABE_ITO["blue"], "solid"), "fluid": (OKABE_ITO["green"], "fluid"),
                "soft_fluid": (OKABE_ITO["orange"], "soft fluid"),
                "undetermined": ("#BBBBBB", "undetermined"), "unknown": ("#FFFFFF", "not analysed")}
#: Matplotlib settings of every figure: legible at 300 dpi in a paper column and on a slide.
STYLE = {"font.size": 10, "axes.titlesize": 10, "axes.labelsize": 11, "legend.fontsize": 8.5,
         "xtick.labelsize": 9, "ytick.labelsize": 9, "lines.linewidth": 1.6, "lines.markersize": 4.5,
         "axes.linewidth": 0.8, "legend.frameon": False, "savefig.dpi": 300,
         "figure.constrained_layout.use": True}
TIME_UNIT = r"$R_0/(\mu F)$"


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
        fig.savefig(p, dpi=dpi)
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


def _flag_words(da) -> dict[int, str]:
    """Code -> word of a CF flag variable, from its attributes (else :data:`PHASE_FLAGS`)."""
    vals, words = da.attrs.get("flag_values"), da.attrs.get("flag_meanings")
    if vals is None or not words:
        return dict(PHASE_FLAGS)
    return {int(v): w for v, w in zip(np.atleast_1d(vals), str(words).split())}


def _phase_words(ds, keep, select) -> np.ndarray:
    """Phase word of every point of the plane; replicates that disagree are
    ``undetermined``, points without a label ``unknown``."""
    da = ds["phase"]
    words = _flag_words(da)
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


def _panels(n, width=3.2, height=2.7, sharey=True):
    """A grid of ``n`` panels (at most 3 per row) with shared axes; spare axes removed."""
    ncols = min(n, 3)
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(width * ncols + 0.9, height * nrows + 0.4),
                             sharex=True, sharey=sharey, squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.remove()
    return fig, flat[:n]


def _grid_label(v) -> str:
    """A grid value in three digits (log-spaced grids give 0.0562341 and the like)."""
    return f"{v:.3g}"


def _grid_ticks(axis, values, most=6):
    """Ticks at the grid values of a log axis (decades alone rarely label a 0.01-0.1
    sweep), in three digits; past ``most`` values only every k-th one is labelled, so
    that refined grids do not print labels on top of each other."""
    values = np.asarray(values, dtype=float)
    step = int(np.ceil(values.size / most))
    axis.set_ticks(values)
    axis.set_ticklabels([_grid_label(v) if i % step == 0 else "" for i, v in enumerate(values)])
    axis.set_minor_formatter(NullFormatter())


def _eta_axis(ax, eta):
    """The x axis of curves against eta: logarithmic where the grid is, labelled."""
    if _log_axis(eta):
        ax.set_xscale("log")
        _grid_ticks(ax.xaxis, eta)
    ax.set_xlabel(r"membrane tension $\eta$")


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

@_styled
def phase_diagram(ds, *, select=None):
    """Phase regions in the (eta, v0) plane, with the <q> = 3.81 and rho_d = 1/2 contours.

    Each grid point is a cell coloured by its phase label (Okabe--Ito: solid blue,
    fluid green, soft fluid orange); ``undetermined`` points (or replicates that
    disagree) are grey and hatched; points without a label are white.  Axes are
    logarithmic where the grid is.  Replicates are reduced (labels must agree,
    observables averaged); other dimensions (N, ...) are taken at ``select`` or their
    last value.  The caption line names N, the run length and the quadrature.
    """
    eta, v0 = ds["eta"].values.astype(float), ds["v0"].values.astype(float)
    words = _phase_words(ds, ("v0", "eta"), select)
    log_x, log_y = _log_axis(eta), _log_axis(v0)
    ex, ey = _edges(eta, log_x), _edges(v0, log_y)
    fig, ax = plt.subplots(figsize=(6.4, 4.3))
    order = ["solid", "fluid", "soft_fluid", "undetermined", "unknown"]
    idx = np.vectorize(lambda w: order.index(w) if w in order else order.index("unknown"))(words)
    cmap = ListedColormap([PHASE_COLORS[w][0] for w in order])
    ax.pcolormesh(ex, ey, idx, cmap=cmap, norm=BoundaryNorm(np.arange(len(order) + 1) - 0.5, len(order)),
                  edgecolors="w", linewidth=0.6)
    for i, j in zip(*np.nonzero(words == "undetermined")):
        ax.add_patch(Rectangle((ex[j], ey[i]), ex[j + 1] - ex[j], ey[i + 1] - ey[i], fill=False,
                               hatch="///", edgecolor="0.35", linewidth=0))
    handles = [Patch(facecolor=PHASE_COLORS[w][0], edgecolor="0.5", label=PHASE_COLORS[w][1],
                     hatch="///" if w == "undetermined" else None)
               for w in order if np.any(words == w)]
    if len(eta) >= 2 and len(v0) >= 2:
        for var, level, style, label in (("q_mean", Q_STAR, "-", r"$\langle q\rangle = 3.81$"),
                                         ("rho_d", RHO_D_PERCOLATION, "--", r"$\rho_d = 1/2$")):
            field = _plane(ds, var, ("v0", "eta"), select).values
            f = np.ma.masked_invalid(field)
            if f.count() >= 4 and np.nanmin(field) < level < np.nanmax(field):
                ax.contour(eta, v0, f, levels=[level], colors="k", linestyles=style, linewidths=2.0)
                handles.append(plt.Line2D([], [], color="k", ls=style, lw=2.0, label=label))
    if log_x:
        ax.set_xscale("log")
    if log_y:
        ax.set_yscale("log")
    for axis, log, vals in ((ax.xaxis, log_x, eta), (ax.yaxis, log_y, v0)):
        if log:
            _grid_ticks(axis, vals)
    ax.set_xlim(ex[0], ex[-1])
    ax.set_ylim(ey[0], ey[-1])
    ax.set_xlabel(r"membrane tension $\eta$")
    ax.set_ylabel(r"self-propulsion $v_0$")
    ax.set_title(caption(ds, select, 95), fontsize=8.5, loc="left")  # 95 characters span the axes and legend
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


@_styled
def d_eff_curves(ds, *, select=None):
    """D_eff against eta, one curve per v0, with 1-sigma error bars where the dataset has
    ``D_eff_err`` and the solid threshold 1e-3; a log axis, symlog where some D_eff <= 0
    (fit noise in a solid)."""
    D = _plane(ds, "D_eff", ("v0", "eta"), select)
    err = _err(ds, "D_eff", ("v0", "eta"), select)
    eta, v0 = D["eta"].values.astype(float), D["v0"].values
    fig, ax = plt.subplots(figsize=(5.6, 3.8))
    for k, col in enumerate(_colors(len(v0))):
        y = D.values[k]
        ok = np.isfinite(y)
        if ok.any():
            ax.errorbar(eta[ok], y[ok], yerr=None if err is None else err[k][ok], fmt="o-", color=col,
                        capsize=2.5)
    ax.axhline(D_EFF_SOLID, color="k", ls=":", lw=1.2)
    ax.text(eta.min() if eta.size else 0, D_EFF_SOLID * 1.3, r" solid below $10^{-3}$", fontsize=8, va="bottom")
    vals = D.values[np.isfinite(D.values)]
    if vals.size and (vals <= 0).any():  # fit noise makes a solid's D_eff <= 0: symlog keeps it
        ax.set_yscale("symlog", linthresh=1e-4, linscale=0.5)
    else:
        ax.set_yscale("log")
        _tidy_log(ax)
    _eta_axis(ax, eta)
    ax.set_ylabel(r"$D_{\rm eff} = D_s / D_0$")
    ax.set_title(caption(ds, select, 70), fontsize=8.5, loc="left")
    _value_colorbar(fig, ax, v0, r"$v_0$")
    return fig


def _per_v0(ds, var, coord, select, draw, ylabel, xlabel, *, sharey=True):
    """One panel per v0 of curves ``var(coord)`` coloured by eta; ``draw(ax, x, y, color)``
    draws one curve and returns True if it drew anything."""
    v0s = ds["v0"].values
    etas = ds["eta"].values
    fig, axes = _panels(len(v0s), sharey=sharey)
    cols = _colors(len(etas))
    for ax, v in zip(axes, v0s):
        sel = {**dict(select or {}), "v0": v}
        c = _plane(ds, var, ("eta", coord), sel)
        drew = False
        for k, e in enumerate(c["eta"].values):
            drew |= bool(draw(ax, c[coord].values, c.sel(eta=e).values, cols[k]))
        if not drew:
            _no_data(ax, "no defect clusters" if var == "cluster_size_distribution" else "no data")
        ax.set_title(rf"$v_0$ = {float(v):g}")
    for ax in axes:
        if ax.get_subplotspec().is_last_row() or len(axes) <= 3:
            ax.set_xlabel(xlabel)
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel(ylabel)
    _value_colorbar(fig, axes, etas, r"$\eta$")
    fig.suptitle(caption(ds, select), fontsize=8.5)
    return fig, axes


@_styled
def q_distributions(ds, *, select=None):
    """Shape-index distributions P(q), one panel per v0, one curve per eta, with q* = 3.81
    and the circle's 2 sqrt(pi) marked."""
    def draw(ax, x, y, col):
        ok = np.isfinite(y)
        if ok.any():
            ax.plot(x[ok], y[ok], color=col)
        return ok.any()

    fig, axes = _per_v0(ds, "q_hist", "q_bin", select, draw, "P(q)", "shape index q")
    for ax in axes:
        ax.axvline(Q_STAR, color="k", ls="--", lw=1)
        ax.axvline(2 * np.sqrt(np.pi), color="0.6", ls=":", lw=1)
    axes[0].text(Q_STAR, 0.97, " q* = 3.81", transform=axes[0].get_xaxis_transform(), va="top", fontsize=8)
    return fig


@_styled
def largest_cluster(ds, *, v0=None, select=None):
    """Largest defect-cluster fraction against eta at one v0 (default: the largest), one
    curve per N, with error bars where ``largest_cluster_fraction_err`` exists."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    p = _plane(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    err = _err(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    fig, ax = plt.subplots(figsize=(5.0, 3.6))
    palette = [OKABE_ITO[c] for c in ("blue", "vermillion", "green", "orange", "purple", "sky", "black")]
    eta = p["eta"].values.astype(float)
    for k, N in enumerate(p["N"].values):
        y = p.values[k]
        ok = np.isfinite(y)
        ax.errorbar(eta[ok], y[ok], yerr=None if err is None else err[k][ok], fmt="o-",
                    color=palette[k % len(palette)], capsize=2.5, label=f"N = {int(N)}")
    _eta_axis(ax, eta)
    ax.set_ylabel(r"$P_{\max} = s_{\max}/N$")
    ax.set_ylim(-0.02, 1.02)
    cap = caption(ds, {k: v for k, v in sel.items() if k != "N"})
    ax.set_title(textwrap.fill(rf"$v_0$ = {float(sel['v0']):g}, " + cap.split(", ", 1)[-1], 60,
                               break_long_words=False), fontsize=8.5, loc="left")
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


@_styled
def cluster_sizes(ds, *, select=None):
    """Defect cluster-size densities n(s), one panel per v0, one curve per eta, with the
    s^(-187/91) percolation guide; a panel without defects says so."""
    smax = max(float(np.nanmax(ds["cluster_size"].values)), 10.0)

    def draw(ax, x, y, col):
        s, d = log_binned(x, y)
        if s.size:
            ax.loglog(s, d, "o-", ms=3, color=col)
        return s.size > 0

    fig, axes = _per_v0(ds, "cluster_size_distribution", "cluster_size", select, draw, "n(s)", "cluster size s")
    s = np.logspace(0, np.log10(smax), 20)
    for ax in axes:
        ax.loglog(s, 0.5 * s ** (-TAU_PERC), "k--", lw=1, label=r"$s^{-187/91}$")
    axes[0].legend(loc="lower left")
    return fig


@_styled
def correlations(ds, *, across="eta", at=None, select=None):
    """G_r(dx, 0) - 1 (symlog: it oscillates about 0) and G6(r) (log-log) with the
    KTHNY -1/3 and -1/4 guides.

    One curve per value of ``across`` ("eta" or "v0") with the other parameter fixed at
    ``at`` (default: its largest value): the paper's Fig. 4 shows both cuts, across v0
    at eta = 0.1 and across eta at v0 = 0.06.
    """
    fixed = "v0" if across == "eta" else "eta"
    sel = dict(select or {})
    sel[fixed] = ds[fixed].values[-1] if at is None else at
    gr = _plane(ds, "Gr", (across, "dx"), sel)
    g6 = _plane(ds, "G6", (across, "r"), sel)
    values = gr[across].values
    label = r"$\eta$" if across == "eta" else r"$v_0$"
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(8.6, 3.6))
    for e, col in zip(values, _colors(len(values))):
        x, y = gr["dx"].values, gr.sel({across: e}).values - 1.0
        ok = np.isfinite(y) & (x > 0)
        if ok.any():
            a1.plot(x[ok], y[ok], "-", lw=1.0, color=col)
        r, y6 = g6["r"].values, g6.sel({across: e}).values
        ok6 = np.isfinite(y6) & (y6 > 0) & (r > 0)
        if ok6.any():
            a2.loglog(r[ok6], y6[ok6], "-", color=col)
    for ax, slope, lab, xs in ((a1, -1 / 3, r"$\propto\Delta x^{-1/3}$", gr["dx"].values),
                               (a2, -1 / 4, r"$\propto r^{-1/4}$", g6["r"].values)):
        xs = xs[np.isfinite(xs) & (xs > 0)]
        if xs.size >= 2:
            x0 = np.array([max(xs.min(), 1.0), xs.max()])
            ax.plot(x0, (x0 / x0[0]) ** slope, "k--", lw=1.2, label=lab)
            ax.legend(loc="lower left")
    a1.set_xscale("log")
    a1.set_yscale("symlog", linthresh=1e-2, linscale=0.6)
    a1.axhline(0, color="0.6", lw=0.8)
    a1.set_xlabel(r"$\Delta x / R_0$")
    a1.set_ylabel(r"$G_r(\Delta x, 0) - 1$")
    a2.set_xlabel(r"$r / R_0$")
    a2.set_ylabel(r"$G_6(r)$")
    fixed_label = r"$v_0$" if fixed == "v0" else r"$\eta$"
    _tidy_log(a1)
    _tidy_log(a2)
    _value_colorbar(fig, [a1, a2], values, label)
    fig.suptitle(f"{fixed_label} = {float(sel[fixed]):g};  " + caption(ds, select), fontsize=8.5)
    return fig


@_styled
def msd_curves(ds, *, v0=None, select=None):
    """MSD against lag time, one curve per eta at one v0 (default: the largest), log-log,
    with the ballistic (slope 2) and diffusive (slope 1) guides."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    m = _plane(ds, "msd", ("eta", "lag_time"), sel)
    fig, ax = plt.subplots(figsize=(5.4, 3.8))
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
    ax.set_title(textwrap.fill(rf"$v_0$ = {float(sel['v0']):g}, " + caption(ds, select), 70, break_long_words=False),
                 fontsize=8.5, loc="left")
    _value_colorbar(fig, ax, etas, r"$\eta$")
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


class FrameArtist:
    """A figure of one frame that can be redrawn with the next frame (for movies).

    Cells are filled by their shape index q (viridis, from the circle's 2 sqrt(pi) to
    4.3), defect cells (Voronoi neighbours != 6) outlined in vermillion with a dot at the
    centroid.
    """

    def __init__(self, box, *, width=6.0):
        self.box = np.asarray(box, dtype=float)
        with plt.rc_context(STYLE):
            self.fig, self.ax = plt.subplots(figsize=(width + 1.1, width * self.box[1] / self.box[0] + 0.5))
            self.coll = PolyCollection([], cmap="viridis", norm=Q_NORM)
            self.ax.add_collection(self.coll)
            (self.dots,) = self.ax.plot([], [], "o", color=OKABE_ITO["vermillion"], ms=2.5)
            cb = self.fig.colorbar(self.coll, ax=self.ax, shrink=0.85, pad=0.02)
            cb.set_label("shape index q")
            cb.ax.axhline(Q_STAR, color="w", lw=1.5)
            self.ax.set_xlim(0, self.box[0])
            self.ax.set_ylim(0, self.box[1])
            self.ax.set_aspect("equal")
            self.ax.set_xlabel(r"$x / R_0$")
            self.ax.set_ylabel(r"$y / R_0$")

    def draw(self, pos, theta, a, b, q, defect, title=""):
        """Replace the drawn frame; returns the figure."""
        polys, owner = cell_polygons(pos, theta, a, b, self.box)
        q = np.asarray(q, dtype=float)
        defect = np.asarray(defect, dtype=bool)
        self.coll.set_verts(polys)
        self.coll.set_array(q[owner])
        self.coll.set_edgecolor(np.where(defect[owner, None], [[0.835, 0.369, 0.0, 1.0]], [[0.15, 0.15, 0.15, 1.0]]))
        self.coll.set_linewidth(np.where(defect[owner], 1.4, 0.3))
        p = np.asarray(pos)
        self.dots.set_data(p[defect, 0], p[defect, 1])
        self.ax.set_title(title or f"N = {len(p)}, defect fraction {defect.mean():.2f}", fontsize=9, loc="left")
        return self.fig

    def rgb(self) -> np.ndarray:
        """The drawn frame as an (H, W, 3) uint8 array."""
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()


def snapshot(pos, theta, a, b, box, q, defect, *, R0=1.0, title=""):
    """One frame: every cell's contour filled by its shape index q, defect cells
    (Voronoi neighbours != 6) outlined with a dot at the centroid."""
    art = FrameArtist(box)
    return art.draw(pos, theta, a, b, q, defect, title)


# ------------------------------------------------------------------ files -> figures

def _find_run(config, run):
    runs = config.runs()
    for spec in runs:
        if spec.run_id == str(run):
            return spec
    try:
        k = int(run)
    except (TypeError, ValueError):
        k = None
    if k is not None and -len(runs) <= k < len(runs):
        return runs[k]
    raise ValueError(f"no run {run!r} in this sweep: give a run id or an index 0..{len(runs) - 1}")


def run_trajectory(config, run) -> Path:
    """Trajectory file of run ``run`` (id or index) of a sweep."""
    from fcsweep.analysis.pipeline import TRAJECTORY_FILE

    spec = _find_run(config, run)
    return Path(config.output) / "runs" / spec.run_id / TRAJECTORY_FILE


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
    p = traj.params
    return (rf"run {p.get('run_id', '')}:  $\eta$ = {p.get('eta', '?')},  $v_0$ = {p.get('v0', '?')},  "
            rf"t = {traj.time[k]:g},  $\rho_d$ = {np.mean(defect):.2f}")


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
    ``every`` recorded frames (H.264 via imageio-ffmpeg).

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
    art = FrameArtist(traj.box / float(traj.params.get("R0", 1.0)))
    art.fig.set_dpi(dpi)
    tmp = out.with_name(f".{out.stem}.partial{out.suffix}")
    try:
        # macro_block_size=16 pads odd sizes; yuv420p plays everywhere (QuickTime, browsers)
        with imageio.get_writer(tmp, fps=fps, codec="libx264", quality=8, macro_block_size=16,
                                pixelformat="yuv420p", ffmpeg_log_level="error") as writer:
            for k in tqdm(frames, desc="movie", unit="frame", disable=not progress):
                pos, theta, a, b, q, defect = _frame(traj, k)
                art.draw(pos, theta, a, b, q, defect, _frame_title(traj, k, defect))
                writer.append_data(art.rgb())
        tmp.replace(out)
    finally:
        plt.close(art.fig)
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


def plot_dataset(ds, outdir) -> list[Path]:
    """All sweep figures of a phase-diagram dataset into ``outdir``."""
    outdir = Path(outdir)
    out = []
    for name, fn in SWEEP_FIGURES.items():
        out += save_figure(fn(ds), outdir / name)
    return out


class NothingToPlot(RuntimeError):
    """The sweep has no analysed run, so every figure would be blank."""


def plot_sweep(config, *, run=None, frame=-1, outdir=None) -> list[Path]:
    """Sweep figures (aggregating first if needed), or the snapshot of run ``run``.

    Raises
    ------
    NothingToPlot
        When no run of the sweep is analysed (nothing is written).
    """
    import xarray as xr

    from fcsweep.analysis.pipeline import DATASET_FILE

    outdir = Path(outdir) if outdir is not None else Path(config.output) / "figures"
    if run is not None:
        spec = _find_run(config, run)
        return snapshot_run(run_trajectory(config, run), frame, outdir / f"snapshot_{spec.run_id}_frame{frame}")
    nc = Path(config.output) / DATASET_FILE
    if nc.exists():
        with xr.open_dataset(nc) as ds:
            ds = ds.load()
    else:
        from fcsweep.analysis.aggregate import build_dataset, write_dataset

        ds = build_dataset(config)
        if int(ds.attrs.get("n_analysed", 0)):
            write_dataset(ds, nc)
    if "status" in ds and not bool((ds["status"] == 0).any()):
        raise NothingToPlot(f"no analysed run in {config.output}: run `fcsweep analyze` first")
    return plot_dataset(ds, outdir)
