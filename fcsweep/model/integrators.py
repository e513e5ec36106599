"""Time integrators of the contour model: names and the contact-implicit factor (pure math).

``"euler"`` is the paper's explicit Euler-Maruyama step.  Its contacts chatter: the
overlap force of a contact grows like its chord, i.e. like the square root of the
overlap depth δ, so the contact's stiffness diverges as it closes, and an explicit step
overshoots every shallow contact into separation (overlap depths are then set by dt,
not by the physics).

``"contact-implicit"`` treats each contact's normal relaxation implicitly.  For one
contact, the gradient flow closes the overlap at the rate

    dδ/dt = u − G c sqrt(δ),        chord L = c sqrt(δ),   c² = 8 / (κ_i + κ_j),

where u is the approach rate from everything else, κ the contour curvatures at the
contact, and G the mobility of the overlap depth per unit force: per cell, 1 for the
centroid plus mu_shape R0² (M − 1) for the shape modes (each mode n moves the contour at
the contact by R0 cos nφ per unit a_n; the cos² + sin² of the M − 1 modes add up).  The
implicit Euler step of the stiff part, δ' = δ − dt G c sqrt(δ'), has the closed form
sqrt(δ') = λ sqrt(δ) with

    λ = sqrt(1 + x²) − x = 1 / (x + sqrt(1 + x²)),    x = 4 dt G / ((κ_i + κ_j) L),

so the step scales every integral of that pair (force, torque, shape sums, of both
cells: action and reaction stay exact) by λ ∈ (0, 1].  A contact never overshoots into
separation under its own force: the map δ → δ' is monotone and converges to the
quasi-static depth (u / (G c))² + dt u instead of alternating between overlap and gap.
As dt → 0, λ = 1 − O(dt): the scheme is consistent and first order, like Euler; noise
is untouched (Euler-Maruyama on θ, added once per step).

The kernels take κ_i + κ_j from the two contours along the contact direction (the
direction of the pair's force; for the point rules, of the mean inside point), floored
at :data:`KAPPA_FLOOR` / R0, and write ``x = coef (2 / R0) / (max(κ_i + κ_j, floor) L)``
with ``coef`` from :func:`contact_coefficient` (the value for two undeformed circles).
The estimate sets how strongly a contact is damped, not what the scheme converges to.
The floor trades the two things the scheme is for: contacts in dense packings are
nearly flat or conforming (κ_i + κ_j ≈ 0.1–0.3 / R0 at the median at ρ = 0.95), and a
lower floor damps them harder (more contacts persist from step to step) but also lags
the contact forces more (the quasi-static depth carries the dt u bias above), which
costs trajectory accuracy; docs/speed_vs_error.md has the measured trade-off.

``"contact-jacobi"`` removes that lag.  The factor of a contact solves the implicit
step of its depth with the approach rate ``u`` that the other forces give it,

    λ² δ = δ + dt u + dt u_own λ,        δ = L² κ / 8,

where u_own < 0 is the rate at which the contact's own (unscaled) integrals close its
depth, measured from its integrals through both cells' mobilities (centroid, rotation,
shape modes, the area-keeping a0: :func:`depth_rate`), so G need not be modelled.  Its
fixed point is λ = 1, the explicit force at the exact quasi-static depth: no dt u
bias.  A contact that the other forces open within the step (δ + dt u <= 0) gets
λ = 0; λ is capped at :data:`JACOBI_MAX_FACTOR`.  The contacts are coupled through
their cells, so the step starts from the explicit forces (λ = 1) and takes
:data:`JACOBI_SWEEPS` Jacobi sweeps: each takes every contact's u from the current
rates, solves its λ, and updates the rates (deterministic for any thread count).  The
depth uses the curvature sum floored at :data:`JACOBI_KAPPA_FLOOR` / R0.  It needs the
arc quadrature (one factor per pair for both cells) and shape modes; in boxes too small
for a cell list (a few cells across) it falls back to the contact-implicit factor.
"""

from __future__ import annotations

import numpy as np

#: Integrator names; ``"euler"`` (the paper's) is the default.
INTEGRATORS = ("euler", "contact-implicit", "contact-jacobi")
DEFAULT_INTEGRATOR = "euler"
#: Floor of the curvature sum κ_i + κ_j (units 1/R0) in the contact law (see above).
KAPPA_FLOOR = 1.0
#: Jacobi sweeps over the contacts per step of ``"contact-jacobi"``.
JACOBI_SWEEPS = 2
#: Largest factor of a contact's integrals under ``"contact-jacobi"``.
JACOBI_MAX_FACTOR = 4.0
#: Floor of κ_i + κ_j (units 1/R0) in the contact depth of ``"contact-jacobi"``.
JACOBI_KAPPA_FLOOR = 0.25


def check_integrator(name) -> str:
    """The integrator name, or ValueError naming the allowed ones."""
    if name not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {list(INTEGRATORS)}; got {name!r}")
    return str(name)


def integrator_problem(integrator, quadrature, modes):
    """Why ``integrator`` cannot run with this quadrature and mode count, or None."""
    if check_integrator(integrator) == "contact-jacobi" and (quadrature != "arc" or modes < 2):
        return (f"integrator 'contact-jacobi' needs quadrature 'arc' and modes >= 2 (one factor per contact for "
                f"both cells); got quadrature {quadrature!r}, modes {modes}: use 'contact-implicit' there")
    return None


def contact_coefficient(integrator, dt, modes, R0=1.0, mu_shape=1.0) -> float:
    """``coef`` of ``x = coef / L`` for a contact of chord L (0 for explicit Euler).

    ``coef = 4 dt G / (κ_i + κ_j)`` with G = 2 (1 + mu_shape R0² (M − 1)) (both cells'
    centroid and shape mobility; 2 for rigid discs) and κ_i + κ_j = 2 / R0.
    """
    if check_integrator(integrator) == "euler":
        return 0.0
    G = 2.0 * (1.0 + (mu_shape * R0 * R0 * (modes - 1) if modes > 0 else 0.0))
    return 2.0 * dt * G * R0


def contour_curvature(a, b, psi, R0=1.0):
    """Curvature (R² + 2R'² − R R'') / (R² + R'²)^(3/2) of a contour at body-frame
    angle(s) ``psi`` (positive where convex); ``a``, ``b`` are one cell's modes n = 2..M."""
    from .shape import a0_of

    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    n = np.arange(2, a.size + 2)
    ang = np.multiply.outer(np.asarray(psi, dtype=float), n)
    c, s = np.cos(ang), np.sin(ang)
    R = R0 * (a0_of(a, b) + c @ a + s @ b)
    R1 = R0 * (n * (b * c - a * s)).sum(axis=-1)
    R2 = -R0 * ((n * n) * (c * a + s * b)).sum(axis=-1)
    q = R * R + R1 * R1
    return (q + R1 * R1 - R * R2) / q ** 1.5


def pair_coefficient(coef, direction, theta_i, a_i, b_i, theta_j, a_j, b_j, R0=1.0, floor=KAPPA_FLOOR):
    """``coef`` of one pair whose contact lies in lab ``direction`` (angle) from cell i:
    ``coef (2 / R0) / max(κ_i + κ_j, floor / R0)``, the curvatures along that line
    (the numpy twin of :func:`fcsweep.kernels.contacts.pair_coef`)."""
    kap = (contour_curvature(a_i, b_i, direction - theta_i, R0)
           + contour_curvature(a_j, b_j, direction + np.pi - theta_j, R0))
    return coef * 2.0 / max(float(kap) * R0, floor)


def contact_factor(chord, coef):
    """Implicit factor λ = 1 / (x + sqrt(1 + x²)), x = coef / chord (1 where chord <= 0).

    Works elementwise on arrays; the numba kernels use the same expression.
    """
    chord = np.asarray(chord, dtype=float)
    with np.errstate(divide="ignore"):
        x = np.where(chord > 0.0, coef / np.where(chord > 0.0, chord, 1.0), 0.0)
    lam = 1.0 / (x + np.sqrt(1.0 + x * x))
    return float(lam) if lam.ndim == 0 else lam


def quasi_static_depth(u, G, c, dt):
    """Fixed point of the contact-implicit map for one contact pushed at rate u > 0:
    δ* = (u / (G c))² + dt u (the exact quasi-static depth plus one step of approach)."""
    return (u / (G * c)) ** 2 + dt * u


def contact_parameters(integrator, dt, modes, R0=1.0, mu_shape=1.0) -> dict:
    """The kernels' contact settings of ``integrator`` (keywords of
    :func:`fcsweep.kernels.api.param_vector`): ``contact``
    (:func:`contact_coefficient`), ``sweeps`` (Jacobi sweeps per step, 0 but for
    contact-jacobi) and ``kappa_floor`` (floor of the curvature sum, units 1/R0)."""
    jacobi = check_integrator(integrator) == "contact-jacobi"
    return {"contact": contact_coefficient(integrator, dt, modes, R0, mu_shape),
            "sweeps": JACOBI_SWEEPS if jacobi else 0,
            "kappa_floor": JACOBI_KAPPA_FLOOR if jacobi else KAPPA_FLOOR}


def jacobi_factor(depth, u_own, u_other, dt, lam_max=None):
    """Factor of a contact under ``"contact-jacobi"``: the positive root of
    λ² δ = δ + dt u_other + dt u_own λ, 0 where δ + dt u_other <= 0, at most ``lam_max``
    (default :data:`JACOBI_MAX_FACTOR`).  Scalars or arrays."""
    depth, u_own, u_other = (np.asarray(x, dtype=float) for x in (depth, u_own, u_other))
    rhs = depth + dt * u_other
    A = np.maximum(-dt * u_own, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = np.where(rhs > 0.0, 2.0 * rhs / (A + np.sqrt(A * A + 4.0 * depth * np.maximum(rhs, 0.0))), 0.0)
    lam = np.minimum(lam, JACOBI_MAX_FACTOR if lam_max is None else lam_max)
    return float(lam) if lam.ndim == 0 else lam


def radial_rate(a, b, da, db, dtheta, psi, R0=1.0):
    """dR/dt of one contour at the fixed lab direction whose body-frame angle is ``psi``,
    for mode rates ``da``, ``db`` and rotation rate ``dtheta`` (with the area-keeping a0;
    the numpy twin of :func:`fcsweep.kernels.contacts.radial_rate`)."""
    from .shape import a0_of

    a, b, da, db = (np.asarray(x, dtype=float) for x in (a, b, da, db))
    n = np.arange(2, a.size + 2)
    c, s = np.cos(n * psi), np.sin(n * psi)
    a0dot = -np.sum(a * da + b * db) / (2.0 * a0_of(a, b))
    dR = np.sum(n * (b * c - a * s))
    return R0 * (a0dot + np.sum(da * c + db * s) - dtheta * dR)


def depth_rate(direction, theta, a, b, rates, i, j, R0=1.0):
    """Rate of change of the overlap depth of cells i and j along the lab ``direction``
    (angle, from i towards j) under ``rates`` (dict of dpos, dtheta, da, db as returned by
    :func:`fcsweep.model.rates.rates`): relative approach of the centroids plus both
    contours' radial rates at the contact."""
    u = np.array([np.cos(direction), np.sin(direction)])
    v = rates["dpos"]
    out = float((v[i] - v[j]) @ u)
    for k, ang in ((i, direction), (j, direction + np.pi)):
        out += radial_rate(a[k], b[k], rates["da"][k], rates["db"][k], rates["dtheta"][k], ang - theta[k], R0)
    return out


__all__ = ["INTEGRATORS", "DEFAULT_INTEGRATOR", "KAPPA_FLOOR", "JACOBI_SWEEPS", "JACOBI_MAX_FACTOR",
           "JACOBI_KAPPA_FLOOR", "check_integrator", "integrator_problem", "contact_parameters",
           "jacobi_factor", "radial_rate", "depth_rate", "contact_coefficient",
           "contour_curvature", "pair_coefficient", "contact_factor", "quasi_static_depth", "contacts",
           "contact_persistence"]


def contacts(pos, theta, a, b, *, box=None, R0=1.0, resolution=1024):
    """Pairs (i, j), i < j, whose exact overlap area is positive, as a set of tuples.

    Uses :func:`fcsweep.model.overlap_exact.overlap_areas` (crossings located on
    ``resolution`` samples per contour, areas exact).
    """
    from .overlap_exact import candidate_pairs, overlap_areas

    theta = np.asarray(theta, dtype=float)
    a = np.asarray(a, dtype=float).reshape(len(theta), -1)
    b = np.asarray(b, dtype=float).reshape(len(theta), -1)
    i, j, d = candidate_pairs(pos, a, b, R0=R0, box=box)
    if i.size == 0:
        return set()
    area = overlap_areas(d, theta[i], a[i], b[i], theta[j], a[j], b[j], R0=R0, resolution=resolution)
    hit = area > 0.0
    return set(zip(i[hit].tolist(), j[hit].tolist()))


def contact_persistence(sets):
    """Fraction of the pairs in contact at one step that are in contact at the next,
    pooled over consecutive entries of ``sets`` (from :func:`contacts`)."""
    kept = total = 0
    for now, nxt in zip(sets[:-1], sets[1:]):
        kept += len(now & nxt)
        total += len(now)
    return kept / total if total else float("nan")


def core_exponent_problem(core_exponent, quadrature, modes, integrator) -> str:
    """Why ``core_exponent`` cannot run with these settings ("" if it can).

    The energy sum A_ij^p needs each pair's overlap area, which the arc rule computes from
    its contact arcs (rigid discs: the lens); the point rules have none, and the contact
    integrators' factors are written for p = 1.  The one statement of the rule: the config,
    :class:`fcsweep.simulation.SimParams`, :func:`fcsweep.model.rates.rates` and
    :func:`fcsweep.kernels.api.kernel_rates` call it.
    """
    if core_exponent == 1.0:
        return ""
    if modes != 0 and quadrature != "arc":
        return (f"core_exponent = {core_exponent:g} needs quadrature 'arc' (or modes 0): the {quadrature!r} rule "
                "has no overlap area per pair")
    if integrator != DEFAULT_INTEGRATOR:
        return f"core_exponent = {core_exponent:g} needs integrator {DEFAULT_INTEGRATOR!r}; got {integrator!r}"
    return ""
