"""Figures of a sweep and of one run (matplotlib, Agg backend; no file reading here).

Every function takes arrays or an :class:`xarray.Dataset` (the phase-diagram dataset) and
returns a :class:`matplotlib.figure.Figure`; :func:`save_figure` writes PNG and PDF.
All functions accept 1-D grids or single points: contours that need a 2-D grid with
values on both sides of the level are skipped.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.colors import LogNorm, Normalize  # noqa: E402

Q_STAR = 3.81
TAU_PERC = 187.0 / 91.0
PHASE_STYLE = {0: ("solid", "s", "tab:blue"), 1: ("fluid", "o", "tab:green"),
               2: ("soft-fluid", "^", "tab:red")}


def save_figure(fig, stem) -> list[Path]:
    """Save ``fig`` as ``<stem>.png`` and ``<stem>.pdf``; close it; return the paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    out = []
    for ext in ("png", "pdf"):
        p = stem.with_suffix(f".{ext}")
        fig.savefig(p, dpi=150, bbox_inches="tight")
        out.append(p)
    plt.close(fig)
    return out


def _plane(ds, var, keep, select=None):
    """``ds[var]`` averaged over replicates (NaN-aware), other extra dims at ``select`` or
    their last value (largest N), keeping the dims ``keep`` in that order."""
    da = ds[var]
    if np.issubdtype(da.dtype, np.integer):
        da = da.where(da >= 0)
    if "replicate" in da.dims and "replicate" not in keep:
        da = da.mean("replicate", skipna=True) if da.sizes["replicate"] > 1 else da.isel(replicate=0)
    select = dict(select or {})
    for d in list(da.dims):
        if d in keep:
            continue
        if d in select:
            da = da.sel({d: select[d]}, method="nearest") if da[d].dtype.kind in "fi" else da.sel({d: select[d]})
        else:
            da = da.isel({d: -1})
    return da.transpose(*keep)


def phase_diagram(ds, *, select=None):
    """D_eff on a log colour scale in (eta, v0), with <q> = 3.81 and rho_d = 1/2 contours
    and the phase of every point marked (solid / fluid / soft-fluid).

    Replicates are averaged; other dimensions (N, ...) are taken at ``select`` or their
    last value.  A 1-D grid or a single point is drawn as coloured markers without
    contours.  D_eff <= 0 is drawn at the bottom of the colour scale.
    """
    eta = ds["eta"].values
    v0 = ds["v0"].values
    D = _plane(ds, "D_eff", ("v0", "eta"), select).values
    q = _plane(ds, "q_mean", ("v0", "eta"), select).values
    rho = _plane(ds, "rho_d", ("v0", "eta"), select).values
    ph = _plane(ds, "phase", ("v0", "eta"), select).values
    fig, ax = plt.subplots(figsize=(5.2, 4.2))
    pos = D[np.isfinite(D) & (D > 0)]
    norm = LogNorm(vmin=max(min(pos.min(), 1e-3) if pos.size else 1e-4, 1e-6),
                   vmax=max(pos.max(), 1e-2) if pos.size else 1.0)
    # D_eff <= 0 (a solid's fit noise) is shown at the bottom of the colour scale
    Dp = np.where(np.isfinite(D), np.clip(D, norm.vmin, None), np.nan)
    if len(eta) >= 2 and len(v0) >= 2:
        m = ax.pcolormesh(eta, v0, Dp, norm=norm, cmap="viridis", shading="nearest")
        for field, level, style, label in ((q, Q_STAR, "-", r"$\langle q\rangle = 3.81$"),
                                           (rho, 0.5, "--", r"$\rho_d = 1/2$")):
            f = np.ma.masked_invalid(field)
            if f.count() >= 4 and np.nanmin(field) < level < np.nanmax(field):
                ax.contour(eta, v0, f, levels=[level], colors="k", linestyles=style)
                ax.plot([], [], "k" + style, label=label)
    else:
        E, V = np.meshgrid(eta, v0)
        m = ax.scatter(E.ravel(), V.ravel(), c=Dp.ravel(), norm=norm, cmap="viridis", s=160)
    fig.colorbar(m, ax=ax, label=r"$D_{\rm eff}$")
    E, V = np.meshgrid(eta, v0)
    for code, (name, marker, _color) in PHASE_STYLE.items():
        sel = ph == code
        if np.any(sel):
            ax.scatter(E[sel], V[sel], marker=marker, facecolors="w", edgecolors="k",
                       linewidths=1.2, s=50, label=name)
    ax.set_xlabel(r"$\eta$")
    ax.set_ylabel(r"$v_0$")
    ax.set_title("phase diagram")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="best", framealpha=0.6)
    return fig


def q_distributions(ds, *, v0=None, select=None):
    """Shape-index distributions for every eta at one v0 (default: the largest)."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    h = _plane(ds, "q_hist", ("eta", "q_bin"), sel)
    fig, ax = plt.subplots(figsize=(5, 3.8))
    cmap = plt.get_cmap("plasma")
    n = h.sizes["eta"]
    for k, e in enumerate(h["eta"].values):
        y = h.sel(eta=e).values
        if np.any(np.isfinite(y)):
            ax.plot(h["q_bin"].values, y, color=cmap(k / max(n - 1, 1)), label=rf"$\eta$={e:g}")
    ax.axvline(Q_STAR, color="k", ls="--", lw=1)
    ax.set_xlabel("q")
    ax.set_ylabel("P(q)")
    ax.set_title(rf"$v_0$ = {float(sel['v0']):g}")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    return fig


def largest_cluster(ds, *, v0=None, select=None):
    """Largest defect-cluster fraction against eta, one curve per N, at one v0."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    p = _plane(ds, "largest_cluster_fraction", ("N", "eta"), sel)
    fig, ax = plt.subplots(figsize=(5, 3.8))
    for N in p["N"].values:
        ax.plot(p["eta"].values, p.sel(N=N).values, "o-", label=f"N = {int(N)}")
    ax.set_xlabel(r"$\eta$")
    ax.set_ylabel(r"$P_{\max} = s_{\max}/N$")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(rf"$v_0$ = {float(sel['v0']):g}")
    ax.legend(fontsize=7)
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


def cluster_sizes(ds, *, v0=None, select=None):
    """Defect cluster-size distributions for every eta at one v0, with the s^-187/91 guide."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    c = _plane(ds, "cluster_size_distribution", ("eta", "cluster_size"), sel)
    fig, ax = plt.subplots(figsize=(5, 3.8))
    cmap = plt.get_cmap("plasma")
    n = c.sizes["eta"]
    ymax = None
    for k, e in enumerate(c["eta"].values):
        s, d = log_binned(c["cluster_size"].values, c.sel(eta=e).values)
        if s.size:
            ax.loglog(s, d, "o-", ms=3, color=cmap(k / max(n - 1, 1)), label=rf"$\eta$={e:g}")
            ymax = d[0] if ymax is None else max(ymax, d[0])
    smax = max(float(c["cluster_size"].values.max()), 10.0)
    s = np.logspace(0, np.log10(smax), 20)
    ax.loglog(s, (ymax or 1.0) * s ** (-TAU_PERC), "k--", lw=1, label=r"$s^{-187/91}$")
    ax.set_xlabel("cluster size s")
    ax.set_ylabel("n(s)")
    ax.set_title(rf"$v_0$ = {float(sel['v0']):g}")
    ax.legend(fontsize=7)
    return fig


def correlations(ds, *, across="eta", at=None, select=None):
    """G_r(dx, 0) - 1 and G6(r) on log-log axes with the KTHNY -1/3 and -1/4 guides.

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
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.8))
    cmap = plt.get_cmap("plasma")
    for k, e in enumerate(values):
        col = cmap(k / max(len(values) - 1, 1))
        y = gr.sel({across: e}).values - 1.0
        x = gr["dx"].values
        ok = np.isfinite(y) & (y > 0)
        if ok.any():
            a1.loglog(x[ok], y[ok], ".", ms=3, color=col, label=f"{label}={e:g}")
        y6 = g6.sel({across: e}).values
        ok6 = np.isfinite(y6) & (y6 > 0)
        if ok6.any():
            a2.loglog(g6["r"].values[ok6], y6[ok6], "-", color=col, label=f"{label}={e:g}")
    for ax, slope, lab, xs in ((a1, -1 / 3, r"$\Delta x^{-1/3}$", gr["dx"].values),
                               (a2, -1 / 4, r"$r^{-1/4}$", g6["r"].values)):
        xs = xs[np.isfinite(xs) & (xs > 0)]
        if xs.size >= 2:
            x0 = np.array([max(xs.min(), 1.0), xs.max()])
            ax.loglog(x0, (x0 / x0[0]) ** slope, "k--", lw=1, label=lab)
        ax.legend(fontsize=7)
    a1.set_xlabel(r"$\Delta x / R_0$")
    a1.set_ylabel(r"$G_r(\Delta x, 0) - 1$")
    a2.set_xlabel(r"$r / R_0$")
    a2.set_ylabel(r"$G_6(r)$")
    fixed_label = r"$v_0$" if fixed == "v0" else r"$\eta$"
    fig.suptitle(f"{fixed_label} = {float(sel[fixed]):g}")
    return fig


def msd_curves(ds, *, v0=None, select=None):
    """MSD against lag time, one curve per eta at one v0, log-log."""
    sel = dict(select or {})
    sel["v0"] = ds["v0"].values[-1] if v0 is None else v0
    m = _plane(ds, "msd", ("eta", "lag_time"), sel)
    fig, ax = plt.subplots(figsize=(5, 3.8))
    cmap = plt.get_cmap("plasma")
    t = m["lag_time"].values
    for k, e in enumerate(m["eta"].values):
        y = m.sel(eta=e).values
        ok = np.isfinite(y) & (y > 0) & (t > 0)
        if ok.any():
            ax.loglog(t[ok], y[ok], color=cmap(k / max(m.sizes["eta"] - 1, 1)), label=rf"$\eta$={e:g}")
    ax.set_xlabel("lag time")
    ax.set_ylabel(r"MSD / $R_0^2$")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    return fig


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


def snapshot(pos, theta, a, b, box, q, defect, *, R0=1.0, title=""):
    """One frame: every cell's contour filled by its shape index q, defect cells
    (Voronoi neighbours != 6) outlined in red with a dot at the centroid."""
    polys, owner = cell_polygons(pos, theta, a, b, box, R0)
    q = np.asarray(q, dtype=float)
    defect = np.asarray(defect, dtype=bool)
    fig, ax = plt.subplots(figsize=(6.5, 6.5 * box[1] / box[0] + 0.5))
    qmin = 2 * np.sqrt(np.pi)
    norm = Normalize(vmin=qmin, vmax=max(4.2, float(np.nanmax(q)) if q.size else 4.2))
    pc = PolyCollection(polys, array=q[owner], cmap="coolwarm", norm=norm,
                        edgecolors=np.where(defect[owner, None], [[0.8, 0, 0, 1]], [[0.2, 0.2, 0.2, 1]]),
                        linewidths=np.where(defect[owner], 1.2, 0.3))
    ax.add_collection(pc)
    p = np.asarray(pos)
    ax.plot(p[defect, 0], p[defect, 1], ".", color="k", ms=3)
    fig.colorbar(pc, ax=ax, label="q", shrink=0.8)
    ax.set_xlim(0, box[0])
    ax.set_ylim(0, box[1])
    ax.set_aspect("equal")
    ax.set_xlabel(r"$x / R_0$")
    ax.set_ylabel(r"$y / R_0$")
    ax.set_title(title or f"N = {len(p)}, defects {defect.mean():.2f}")
    return fig
