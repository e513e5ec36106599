"""Measured movies (``fcsweep measure``) beside the simulated points on the <q> - rho_d plane.

The phase diagram's axes are eta and v0, which an experiment does not know; <q> and rho_d
both sides have.  Each simulated grid point (replicate mean, largest N) is a dot coloured
by its phase label, with its error bars; each measured movie a black diamond with the
errors of its frame averages (``q_mean_movie``, ``rho_d_movie``), named by its file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fcsweep.results.figures.common import (COLUMN, PHASE_COLORS, error_of, on_plane, own_axes, phase_words, styled)
from fcsweep.analysis.phase import RHO_D_PERCOLATION
from fcsweep.model.shape import Q_STAR

__all__ = ["measured_plane"]


@styled
def measured_plane(ds, measured, *, names=None, ax=None):
    """The <q> - rho_d plane of a sweep with measured movies on it.

    Parameters
    ----------
    ds : xarray.Dataset
        Phase-diagram dataset (``q_mean``, ``rho_d``; ``phase`` and the ``_err`` variables
        where present).
    measured : list of xarray.Dataset
        ``measure.nc`` datasets (``q_mean_movie``, ``rho_d_movie`` and their ``_err``).
    names : list of str, optional
        Legend name of each measured dataset (default: its ``source`` attribute).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = own_axes(ax, (COLUMN, COLUMN * 1.2))
    keep = ("eta", "v0")
    q = on_plane(ds, "q_mean", keep).values.ravel()
    rho = on_plane(ds, "rho_d", keep).values.ravel()
    qe, re = error_of(ds, "q_mean", keep, None), error_of(ds, "rho_d", keep, None)
    words = phase_words(ds, keep, None).ravel() if "phase" in ds else np.full(q.size, "unknown")
    for word in dict.fromkeys(words):
        sel = (words == word) & np.isfinite(q) & np.isfinite(rho)
        if not sel.any():
            continue
        color, label = PHASE_COLORS.get(word, ("#BBBBBB", word))
        ax.errorbar(q[sel], rho[sel], xerr=None if qe is None else qe.ravel()[sel],
                    yerr=None if re is None else re.ravel()[sel], fmt="o", color=color, mec="k", mew=0.4,
                    elinewidth=0.6, label=f"simulated: {label}")
    for k, m in enumerate(measured):
        name = (names[k] if names else None) or Path(str(m.attrs.get("source", f"movie {k + 1}"))).name
        name = name if len(name) <= 28 else name[:27] + "…"
        ax.errorbar(float(m["q_mean_movie"]), float(m["rho_d_movie"]), xerr=float(m["q_mean_movie_err"]),
                    yerr=float(m["rho_d_movie_err"]), fmt="D", color="k", mfc="w" if k % 2 else "k", ms=5,
                    label=f"measured: {name}")
    ax.axvline(Q_STAR, color="0.5", lw=0.7, ls="--")
    ax.axhline(RHO_D_PERCOLATION, color="0.5", lw=0.7, ls=":")
    ax.set_xlabel(r"shape index $\langle q\rangle$")
    ax.set_ylabel(r"defect fraction $\rho_d$")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=1)
    return fig
