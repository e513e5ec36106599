"""Curves per grid point: shape-index distributions, the largest defect cluster,
cluster sizes, G_r and G6 correlations, MSDs (Fig. 2e-g, 3a-b, 4a-d)."""

from __future__ import annotations

import textwrap

import matplotlib.pyplot as plt
import numpy as np

from fcsweep.results.figures.common import (CAPTION_SIZE, COLUMN, DOUBLE_COLUMN, ETA_SYMBOL, OKABE_ITO, TAU_PERC,
                                            TIME_UNIT, V0_SYMBOL, caption, caption_chars, error_of, eta_axis, no_data,
                                            on_plane, own_axes, panel_axes, styled, tidy_log, value_colorbar,
                                            value_colors)
from fcsweep.model.shape import Q_STAR


def _per_v0(ds, var, coord, select, draw, ylabel, xlabel, *, sharey=True, axes=None):
    """One panel per v0 of curves ``var(coord)`` coloured by eta; ``draw(ax, x, y, color)``
    draws one curve and returns True if it drew anything.  ``axes``: one Axes per v0 to
    draw into (else a new figure).  The eta colour bar is added only where a curve is."""
    v0s = ds["v0"].values
    etas = ds["eta"].values
    own = axes is None
    if own:
        fig, axes = panel_axes(len(v0s), sharey=sharey)
    else:
        axes = list(axes)
        if len(axes) != len(v0s):
            raise ValueError(f"{len(v0s)} Axes needed (one per v0), got {len(axes)}")
        fig = axes[0].figure
    cols = value_colors(len(etas))
    drew_any = False
    for ax, v in zip(axes, v0s):
        sel = {**dict(select or {}), "v0": v}
        c = on_plane(ds, var, ("eta", coord), sel)
        drew = False
        for k, e in enumerate(c["eta"].values):
            drew |= bool(draw(ax, c[coord].values, c.sel(eta=e).values, cols[k]))
        if not drew:
            no_data(ax, "no defect clusters" if var == "cluster_size_distribution" else "no data")
        drew_any |= drew
        ax.set_title(rf"$v_0$ = {float(v):g} $\mu F$")
    for ax in axes:
        spec = ax.get_subplotspec()
        if spec is None or spec.is_last_row() or len(axes) <= 3:
            ax.set_xlabel(xlabel)
        if spec is None or spec.is_first_col():
            ax.set_ylabel(ylabel)
    if drew_any:
        value_colorbar(fig, axes, etas, ETA_SYMBOL)
    else:  # empty panels: no scale to read
        for ax in axes:
            ax.tick_params(which="both", left=False, bottom=False, labelleft=False, labelbottom=False)
    if own:
        fig.suptitle(caption(ds, select), fontsize=CAPTION_SIZE)
    return fig, axes


@styled
def q_distributions(ds, *, select=None, axes=None):
    """Shape-index distributions P(q), one panel per v0, one curve per eta, with q* = 3.81
    and the circle's 2 sqrt(pi) marked (named in a legend on the first panel).  ``axes``:
    one Axes per v0 to draw into."""
    def draw(ax, x, y, col):
        ok = np.isfinite(y)
        if ok.any():
            ax.plot(x[ok], y[ok], color=col)
        return ok.any()

    fig, axes = _per_v0(ds, "q_hist", "q_bin", select, draw, "P(q)", "shape index q", axes=axes)
    marks = ((Q_STAR, dict(color="k", ls="--", lw=0.9), "q* = 3.81"),
             (2 * np.sqrt(np.pi), dict(color="0.6", ls=":", lw=0.9), r"circle, $2\sqrt{\pi}$ = 3.545"))
    for ax in axes:
        for x, style, _ in marks:
            ax.axvline(x, **style)
    axes[0].legend(handles=[plt.Line2D([], [], label=text, **style) for _, style, text in marks], loc="upper right",
                   handlelength=1.6, fontsize=6, framealpha=0.85)
    return fig


@styled
def largest_cluster(ds, *, v0=None, select=None, ax=None):
    """Largest defect-cluster fraction against eta at one v0 (default: the largest), one
    curve per N, with error bars where ``largest_cluster_fraction_err`` exists.
    ``ax``: draw into this Axes (else a new figure one column wide)."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    p = on_plane(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    err = error_of(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    own = ax is None
    fig, ax = own_axes(ax, (COLUMN, 2.7))
    palette = [OKABE_ITO[c] for c in ("blue", "vermillion", "green", "orange", "purple", "sky", "black")]
    eta = p["eta"].values.astype(float)
    for k, N in enumerate(p["N"].values):
        y = p.values[k]
        ok = np.isfinite(y)
        ax.errorbar(eta[ok], y[ok], yerr=None if err is None else err[k][ok], fmt="o-",
                    color=palette[k % len(palette)], capsize=2.0, label=f"N = {int(N)}")
    eta_axis(ax, eta)
    ax.set_ylabel(r"$P_{\max} = s_{\max}/N$")
    ax.set_ylim(-0.02, 1.02)
    head = rf"$v_0$ = {float(sel['v0']):g} $\mu F$"
    if own:
        cap = caption(ds, {k: v for k, v in sel.items() if k != "N"})
        head += ", " + cap.split(", ", 1)[-1]
    ax.set_title(textwrap.fill(head, caption_chars(ax), break_long_words=False), fontsize=CAPTION_SIZE,
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


@styled
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


@styled
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
    gr = on_plane(ds, "Gr", (across, "dx"), sel)
    g6 = on_plane(ds, "G6", (across, "r"), sel)
    values = gr[across].values
    label = ETA_SYMBOL if across == "eta" else V0_SYMBOL
    own = axes is None
    if own:
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(DOUBLE_COLUMN, 2.7))
    else:
        a1, a2 = axes
        fig = a1.figure
    for e, col in zip(values, value_colors(len(values))):
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
    tidy_log(a1)
    tidy_log(a2)
    if a1.get_lines() or a2.get_lines():
        value_colorbar(fig, [a1, a2], values, label)
    if own:
        fig.suptitle(f"{fixed_label};  " + caption(ds, select), fontsize=CAPTION_SIZE)
    else:
        a1.set_title(fixed_label, loc="left")
    return fig


@styled
def msd_curves(ds, *, v0=None, select=None, ax=None):
    """MSD against lag time, one curve per eta at one v0 (default: the largest), log-log,
    with the ballistic (slope 2) and diffusive (slope 1) guides.  ``ax``: draw into this
    Axes (else a new figure one column wide)."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    m = on_plane(ds, "msd", ("eta", "lag_time"), sel)
    own = ax is None
    fig, ax = own_axes(ax, (COLUMN, 2.7))
    t = m["lag_time"].values
    etas = m["eta"].values
    first = []
    for e, col in zip(etas, value_colors(len(etas))):
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
    tidy_log(ax)
    ax.set_xlabel(f"lag time t [{TIME_UNIT}]")
    ax.set_ylabel(r"MSD / $R_0^2$")
    head = rf"$v_0$ = {float(sel['v0']):g} $\mu F$"
    if own:
        head += ", " + caption(ds, select)
    ax.set_title(textwrap.fill(head, caption_chars(ax), break_long_words=False), fontsize=CAPTION_SIZE,
                 loc="left")
    if first:
        value_colorbar(fig, ax, etas, ETA_SYMBOL)
    return fig
