"""Python entry points to the numba kernels (array in, array out)."""

from __future__ import annotations

import numpy as np

from ..model.integrators import JACOBI_MAX_FACTOR, KAPPA_FLOOR, core_exponent_problem
from .records import (N_PARAMS, P_ADH, P_ADHR, P_CONTACT, P_CORE, P_DMAX, P_DT, P_ETA, P_KFLOOR, P_LAMMAX, P_LX,
                      P_LY, P_MUS, P_MUT, P_NOISE, P_R0, P_SKIN, P_SMAX, P_SWEEPS, P_V0, P_WALL, P_WALLA)
from .step import compute_rates
from .workspace import SKIN, quadrature_code, workspace_for


def param_vector(*, box, R0, eta, v0, mu_theta, mu_shape, dt=0.0, noise_amp=0.0, smax=np.inf, dmax=np.inf,
                 contact=0.0, sweeps=0, kappa_floor=KAPPA_FLOOR, adhesion=0.0, adhesion_range=0.1,
                 core_exponent=1.0, wall=None):
    """Float parameter vector in the layout :func:`fcsweep.kernels.step.run_chunk` reads.

    ``contact``, ``sweeps`` and ``kappa_floor`` are an integrator's contact settings
    (:func:`fcsweep.model.integrators.contact_parameters`; the defaults are Euler's);
    ``core_exponent`` the power of the overlap area in the energy (1: the paper's).
    ``adhesion`` and ``adhesion_range`` (in R0) are :mod:`fcsweep.model.adhesion`'s gamma and
    delta / R0; with ``adhesion = 0`` the vector holds zeros for both and the step is today's.
    ``wall`` is a :class:`fcsweep.model.confinement.Confinement` (``None``: the periodic box,
    no wall term); ``box`` is then its host box.
    """
    prm = np.zeros(N_PARAMS)
    Lx, Ly = (1.0, 1.0) if box is None else (float(box[0]), float(box[1]))
    prm[P_LX], prm[P_LY], prm[P_R0] = Lx, Ly, R0
    prm[P_ETA], prm[P_V0], prm[P_MUT], prm[P_MUS] = eta, v0, mu_theta, mu_shape
    prm[P_DT], prm[P_NOISE], prm[P_SMAX], prm[P_DMAX] = dt, noise_amp, smax, dmax
    prm[P_SKIN] = SKIN * R0
    prm[P_CONTACT] = contact
    prm[P_KFLOOR] = kappa_floor
    prm[P_SWEEPS] = sweeps
    prm[P_LAMMAX] = JACOBI_MAX_FACTOR
    if adhesion > 0.0:
        prm[P_ADH] = adhesion
        prm[P_ADHR] = adhesion_range * R0
    prm[P_CORE] = core_exponent
    if wall is not None:
        prm[P_WALL] = wall.code
        prm[P_WALLA:P_WALLA + 3] = wall.kernel_values()
    return prm


def wrap_positions(pos, box):
    """Positions wrapped into [0, Lx) x [0, Ly) (a copy); unchanged for open boundaries."""
    pos = np.array(pos, dtype=float)
    if box is not None:
        pos = np.mod(pos, np.asarray(box, dtype=float))
        pos[pos[:, 0] >= box[0], 0] = 0.0
        pos[pos[:, 1] >= box[1], 1] = 0.0
    return pos


def kernel_rates(pos, theta, a, b, *, eta, v0, box=None, R0=1.0, contour_points=40, quadrature="arc",
                 mu_theta=1.0, mu_shape=1.0, workspace=None, contact=0.0, sweeps=0, kappa_floor=KAPPA_FLOOR,
                 dt=0.0, adhesion=0.0, adhesion_range=0.1, core_exponent=1.0, radii=None, wall=None):
    """Deterministic rates computed by the numba kernels; same contract as
    :func:`fcsweep.model.rates.rates`.

    ``contact > 0`` gives the effective rates of one contact-implicit step instead
    (each pair's integrals scaled by its factor; see :mod:`fcsweep.model.integrators`),
    and ``sweeps > 0`` as well those of one contact-jacobi step of length ``dt``.
    ``adhesion > 0`` adds the adhesion rates (:func:`fcsweep.model.adhesion.adhesion_rates`).
    ``core_exponent`` p != 1 (the energy sum_ij A_ij^p) needs the arc rule or
    ``modes = 0`` and the Euler rates (ValueError otherwise).  ``radii`` (N,) are
    per-cell radii R0,i (cell size differences; Euler rates only); with a given
    ``workspace`` they are those it was made with.  ``wall`` (a
    :class:`fcsweep.model.confinement.Confinement`) adds the wall's rates; ``box`` is then
    its host box (``wall.host`` when ``box`` is None).
    """
    if wall is not None and box is None:
        box = wall.host
    if radii is not None and (contact > 0.0 or sweeps > 0):
        raise ValueError("per-cell radii need the euler integrator (contact = sweeps = 0)")
    pos = np.ascontiguousarray(pos, dtype=float).reshape(-1, 2)
    N = len(pos)
    theta = np.ascontiguousarray(theta, dtype=float).reshape(N)
    a = np.ascontiguousarray(a, dtype=float).reshape(N, -1)
    b = np.ascontiguousarray(b, dtype=float).reshape(N, -1)
    integrator = "contact-jacobi" if sweeps > 0 else "contact-implicit" if contact > 0.0 else "euler"
    problem = core_exponent_problem(core_exponent, quadrature, a.shape[1] + 1 if a.shape[1] else 0, integrator)
    if problem:
        raise ValueError(problem)
    ws = workspace or workspace_for(N, contour_points, a.shape[1], box, R0, quadrature,
                                    "contact-jacobi" if sweeps > 0 else "euler", radii=radii)
    if quadrature == "arc" and a.shape[1] > 0 and not ws.pair_buffer:
        raise ValueError("the arc quadrature needs a Workspace with pair_buffer=True")
    if sweeps > 0 and not ws.pair_records:
        raise ValueError("contact-jacobi needs a Workspace with pair_records=True")
    prm = param_vector(box=box, R0=R0, eta=eta, v0=v0, mu_theta=mu_theta, mu_shape=mu_shape, contact=contact,
                       sweeps=sweeps, kappa_floor=kappa_floor, dt=dt, adhesion=adhesion,
                       adhesion_range=adhesion_range, core_exponent=core_exponent, wall=wall)
    pos = wrap_positions(pos, box)
    ws.nl[4][0] = 0  # positions are new: rebuild the neighbour list
    while not compute_rates(pos, theta, a, b, prm, box is not None, quadrature_code(quadrature),
                            ws.tables, ws.scratch, ws.cl, ws.nl, ws.out):
        ws.grow_neighbour_list()
    dpos, dth, da, db = ws.out
    return {"dpos": dpos.copy(), "dtheta": dth.copy(), "da": da.copy(), "db": db.copy()}
