"""Finite-size scaling of defect percolation: the collapse (Fig. 3c) and P_max
against rho_d per N (Fig. S7)."""

from __future__ import annotations

import textwrap

import numpy as np

from fcsweep.results.figures.common import (CAPTION_SIZE, COLUMN, OKABE_ITO, caption, caption_chars, error_of, no_data,
                                            on_plane, own_axes, reduce_to, styled)
from fcsweep.analysis.phase import RHO_D_PERCOLATION


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
        rho = reduce_to(ds["rho_d_rmean"], keep, sel).values
        p = reduce_to(ds["largest_cluster_fraction_rmean"], keep, sel).values
        e = reduce_to(ds["largest_cluster_fraction_rmean_err"], keep, sel).values
    else:
        rho = on_plane(ds, "rho_d", keep, sel).values
        p = on_plane(ds, "largest_cluster_fraction", keep, sel).values
        e = error_of(ds, "largest_cluster_fraction", keep, sel)
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
    ax.set_title(textwrap.fill(head, caption_chars(ax), break_long_words=False), fontsize=CAPTION_SIZE,
                 loc="left")


@styled
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
        (:func:`fcsweep.analysis.fss.fss_collapse` with ``fixed``).
    ax : matplotlib.axes.Axes, optional
        Draw into this Axes (else a new figure one column wide).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from fcsweep.analysis.fss import BETA_2D, NU_2D, fss_collapse, fss_scaled

    if exponents not in ("fit", "paper"):
        raise ValueError(f"exponents must be 'fit' or 'paper', got {exponents!r}")
    rho, p, e, N, sel = _fss_slice(ds, select)
    own = ax is None
    fig, ax = own_axes(ax, (COLUMN, 2.7))
    ok = np.isfinite(rho) & np.isfinite(p)
    fit, why = None, ""
    if exponents == "fit" and "fss_rho_c" in ds:
        vals = {k: float(reduce_to(ds[f"fss_{k}"], (), sel).values)
                for k in ("rho_c", "rho_c_err", "nu", "nu_err", "beta", "beta_err")}
        if np.isfinite(vals["rho_c"]):
            fit = vals
        else:
            why = str(reduce_to(ds["fss_reason"], (), sel).values) if "fss_reason" in ds else "no fit"
    elif np.unique(N[ok]).size >= 2:
        fixed = {"nu": NU_2D, "beta": BETA_2D} if exponents == "paper" else None
        r = fss_collapse(rho[ok], p[ok], N[ok], np.where(np.isfinite(e[ok]), e[ok], 0.0), fixed=fixed,
                         n_bootstrap=0)
        fit = dict(r) if np.isfinite(r.rho_c) else None
        why = r.reason
    else:
        why = "fewer than two N with data"
    if fit is None:
        no_data(ax, textwrap.fill(f"no collapse: {why}", 40))
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


@styled
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
    fig, ax = own_axes(ax, (COLUMN, 2.7))
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
        no_data(ax)
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
