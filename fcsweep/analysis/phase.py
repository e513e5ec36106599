"""Phase and percolation labels (MODEL.md): integer codes with CF flag attributes.

solid       if D_eff < 1e-3;
soft-fluid  otherwise, if <q> > 3.81;
fluid       otherwise.
percolated  if rho_d > 1/2.
Unknown (-1) wherever an input is NaN.
"""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.diffusion import D_EFF_SOLID
from fcsweep.model.shape import Q_STAR

#: Percolation threshold of the defect fraction (site percolation on a triangular lattice).
RHO_D_PERCOLATION = 0.5

PHASE_UNKNOWN, PHASE_SOLID, PHASE_FLUID, PHASE_SOFT_FLUID = -1, 0, 1, 2
#: Codes and CF ``flag_meanings`` (blank-separated words) of the phase label.
PHASE_FLAGS = {PHASE_UNKNOWN: "unknown", PHASE_SOLID: "solid", PHASE_FLUID: "fluid",
               PHASE_SOFT_FLUID: "soft_fluid"}
#: Codes of the percolation label.
PERCOLATION_FLAGS = {-1: "unknown", 0: "not_percolated", 1: "percolated"}


def phase_code(D_eff, q_mean, *, d_solid: float = D_EFF_SOLID, q_star: float = Q_STAR):
    """Integer phase code(s) from D_eff and <q> (arrays broadcast).

    Returns
    -------
    ndarray of int8
        0 solid, 1 fluid, 2 soft-fluid, -1 unknown (D_eff NaN, or <q> NaN when fluid).
    """
    D = np.asarray(D_eff, dtype=float)
    q = np.asarray(q_mean, dtype=float)
    D, q = np.broadcast_arrays(D, q)
    out = np.full(D.shape, PHASE_UNKNOWN, dtype=np.int8)
    solid = np.isfinite(D) & (D < d_solid)
    moving = np.isfinite(D) & (D >= d_solid) & np.isfinite(q)
    out[solid] = PHASE_SOLID
    out[moving & (q > q_star)] = PHASE_SOFT_FLUID
    out[moving & ~(q > q_star)] = PHASE_FLUID
    return out


def phase_name(code: int) -> str:
    """Human-readable name of a phase code ('soft-fluid' with a hyphen)."""
    return PHASE_FLAGS.get(int(code), "unknown").replace("_", "-")


def percolation_code(rho_d, *, threshold: float = RHO_D_PERCOLATION):
    """1 where rho_d > threshold, 0 where not, -1 where rho_d is NaN (int8 array)."""
    r = np.asarray(rho_d, dtype=float)
    out = np.full(r.shape, -1, dtype=np.int8)
    ok = np.isfinite(r)
    out[ok] = (r[ok] > threshold).astype(np.int8)
    return out


def flag_attrs(flags: dict) -> dict:
    """CF ``flag_values`` / ``flag_meanings`` attributes for an int8 code variable."""
    keys = sorted(flags)
    return {"flag_values": np.array(keys, dtype=np.int8),
            "flag_meanings": " ".join(flags[k] for k in keys)}
