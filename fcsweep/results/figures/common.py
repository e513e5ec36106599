"""Shared parts of the figures: style, palettes, units, saving, and reading planes,
errors and labels out of the phase-diagram dataset.  Its helpers are public names for the
modules of the figures package (not re-exported by :mod:`fcsweep.results.figures`)."""

from __future__ import annotations

from pathlib import Path
import functools
import json
import textwrap

from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
import matplotlib.pyplot as plt
import numpy as np

from fcsweep.analysis.phase import PHASE_FLAGS
from fcsweep.io.failures import remove_stale
from fcsweep.io.sweepdir import atomic_write


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


def styled(fn):
    """Draw ``fn``'s figure with :data:`STYLE`."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with plt.rc_context(STYLE):
            return fn(*args, **kwargs)
    return wrapper


def save_figure(fig, stem, *, dpi: int = 300) -> list[Path]:
    """Save ``fig`` as ``<stem>.png`` (``dpi``) and ``<stem>.pdf``; close it; return the paths.

    Each file is written whole or not at all (:func:`fcsweep.io.sweepdir.atomic_write`):
    a figure set that fails part way holds complete new files and complete old ones.
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    out = []
    try:
        for ext in ("png", "pdf"):
            p = stem.with_suffix(f".{ext}")
            remove_stale(p.parent, (p.name,))
            # bbox_inches="tight": legends below the axes stay in
            atomic_write(p, lambda tmp, ext=ext: fig.savefig(tmp, format=ext, dpi=dpi, bbox_inches="tight",
                                                            pad_inches=0.03), fsync=True)
            out.append(p)
    finally:
        plt.close(fig)
    return out


def on_plane(ds, var, keep, select=None):
    """``ds[var]`` averaged over replicates (NaN-aware), other extra dims at ``select`` or
    their last value (largest N), keeping the dims ``keep`` in that order."""
    da = ds[var]
    if np.issubdtype(da.dtype, np.integer):
        da = da.where(da >= 0)
    if "replicate" in da.dims and "replicate" not in keep:
        da = da.mean("replicate", skipna=True) if da.sizes["replicate"] > 1 else da.isel(replicate=0)
    return reduce_to(da, keep, select)


def reduce_to(da, keep, select):
    select = dict(select or {})
    for d in list(da.dims):
        if d in keep:
            continue
        if d in select:
            da = da.sel({d: select[d]}, method="nearest") if da[d].dtype.kind in "fi" else da.sel({d: select[d]})
        else:
            da = da.isel({d: -1})
    return da.transpose(*keep)


def error_of(ds, var, keep, select):
    """The 1-sigma error of ``var`` (``<var>_err``) on the same plane, or None; replicates
    are combined as the error of their mean."""
    name = f"{var}_err"
    if name not in ds:
        return None
    da = ds[name]
    if "replicate" in da.dims and "replicate" not in keep:
        n = np.isfinite(da).sum("replicate")
        da = np.sqrt((da ** 2).sum("replicate", skipna=True)) / n.where(n > 0)
    return reduce_to(da, keep, select).values


def flag_words(da, default=None) -> dict[int, str]:
    """Code -> word of a CF flag variable, from its attributes (else ``default``,
    :data:`PHASE_FLAGS` if not given)."""
    vals, words = da.attrs.get("flag_values"), da.attrs.get("flag_meanings")
    if vals is None or not words:
        return dict(PHASE_FLAGS if default is None else default)
    return {int(v): w for v, w in zip(np.atleast_1d(vals), str(words).split())}


def phase_words(ds, keep, select, var="phase", default=None) -> np.ndarray:
    """Label word of every point of the plane (of ``var``, a CF flag variable);
    replicates, or starts (``initial``), that do not all give the same label are
    ``undetermined`` (the point rule of :mod:`fcsweep.analysis.points`), points without a
    label ``unknown``."""
    da = ds[var]
    words = flag_words(da, default)
    over = [d for d in ("replicate", "initial") if d in da.dims and d not in keep]
    if over:
        da = da.where(da >= 0)
        lo, hi = da.min(over, skipna=True), da.max(over, skipna=True)
        da = lo.where((lo == hi) | lo.isnull(), -2)  # -2: they disagree; NaN: no label at all
    codes = reduce_to(da, keep, select).values
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


def log_axis(values) -> bool:
    """Log axis for a logarithmic grid, and for positive values whose linear cells
    would reach zero or below (two points a decade apart: eta 0.01 and 0.1)."""
    v = np.asarray(values, dtype=float)
    if _is_log_grid(v):
        return True
    return v.size >= 2 and bool(np.all(v > 0)) and cell_edges(v, False)[0] <= 0


def cell_edges(values, log: bool) -> np.ndarray:
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


def _run_ends(ds, select) -> np.ndarray:
    """Finite end times ``t_end`` of the runs on the selection (every run where a
    swept dimension is not selected); empty without ``t_end``."""
    if "t_end" not in ds:
        return np.array([])
    da = ds["t_end"]
    v = reduce_to(da, [d for d in da.dims if d not in (select or {})], select).values.astype(float).ravel()
    return v[np.isfinite(v)]


def caption(ds, select=None, width: int | None = None) -> str:
    """One line naming what a figure shows: N, run length, quadrature, modes/points,
    D_r and the number of replicates (from the dataset's config attribute; the run
    length from the runs' ``t_end`` where they ran longer or shorter than the config
    says, as extended or settled runs do); wrapped at ``width`` characters if given."""
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
        ends = _run_ends(ds, select)
        ran = bool(dt) and ends.size > 0 and (ends.min() < ends.max() or not np.isclose(ends.max(), steps * dt))
        if ran:  # runs extended past (or settled before) the config's length: say what ran
            lo, hi = ends.min(), ends.max()
            length = f"{lo:g}" + (f"-{hi:g}" if lo < hi else "") + " time units"
            length += f" (cap {steps * dt:g})" if until else ""
        head = "runs of up to" if until and not ran else "runs of"
        parts.append(f"{head} {length}" + (", stopped when settled" if until else ""))
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


def value_colors(n):
    """``n`` ordered colours from viridis, stopping before its pale yellow end."""
    return plt.get_cmap("viridis")(np.linspace(0.0, 0.85, max(n, 1)))


def value_colorbar(fig, axes, values, label):
    """A discrete colour bar naming the value of each curve's colour."""
    n = len(values)
    cmap = ListedColormap(value_colors(n))
    sm = plt.cm.ScalarMappable(norm=BoundaryNorm(np.arange(n + 1) - 0.5, n), cmap=cmap)
    cb = fig.colorbar(sm, ax=axes, ticks=np.arange(n), aspect=30, pad=0.02)
    cb.ax.set_yticklabels([_grid_label(v) for v in values])
    cb.set_label(label)
    return cb


def caption_chars(ax) -> int:
    """Characters of a caption line (at :data:`CAPTION_SIZE`) that fit over ``ax``."""
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72.0
    return max(int(width_pt / (0.55 * CAPTION_SIZE)), 30)


def own_axes(ax, size):
    """``(figure, ax)``: the given Axes and its figure, or a new figure of ``size`` inches."""
    if ax is not None:
        return ax.figure, ax
    return plt.subplots(figsize=size)


def panel_axes(n, width=None, height=1.9, sharey=True):
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


def grid_ticks(axis, values, most=None):
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


def eta_axis(ax, eta):
    """The x axis of curves against eta: logarithmic where the grid is, labelled."""
    if log_axis(eta):
        ax.set_xscale("log")
        grid_ticks(ax.xaxis, eta)
    ax.set_xlabel(ETA_LABEL)


def tidy_log(ax):
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


def no_data(ax, text="no data"):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.3",
            bbox={"facecolor": "w", "edgecolor": "none", "alpha": 0.9})
