"""Confinement: a circular well or a channel instead of the periodic box (pure numpy).

The wall acts on a cell's contour as another cell's overlap does: its energy is the area
of the cell that lies outside the confinement,

    E_wall = sum_i A(i outside),

so its rates are the overlap rates of docs/model.md with the occupancy o_ik replaced by
the fraction of contour point k's arc that lies outside (the ``binary`` rule: whether the
point lies outside; ``linear`` and ``arc``: the fraction from the radial gap interpolated
linearly between adjacent points, exact for a straight wall up to the curvature of the
contour; rigid discs, ``modes: 0``: the exact chord of the disc's part outside).  The
core exponent applies to cell-cell overlaps only; the wall's energy is its area.

Geometry (:class:`Confinement`):

* ``well``: a disc of radius R_w centred in a square host box;
* ``channel``: walls at y = y_lo and y = y_hi = y_lo + W, periodic along x.

The kernels run in a *host* periodic box that holds the confinement with an empty margin
wider than any interaction range on every walled side, so that no cell meets another's
periodic image across a wall, the cell list and its minimum image are today's, and the
positions, image counters and unwrapping of the trajectory keep their meaning.  ``N`` is
the number of cells; the area they are confined to is pi R_w^2 (well) or W L_x (channel),
and the area fraction is sum_i pi R0,i^2 over that area.

Sizes (``boundary_size``, in R0):

* ``well``: R_w = boundary_size R0; 0 (default): R_w from the area fraction,
  pi R_w^2 = sum_i pi R0,i^2 / density.  With boundary_size given ``density`` is not
  used (the area fraction is sum_i R0,i^2 / R_w^2, :func:`Confinement.area_fraction`).
* ``channel``: W = boundary_size R0; 0: the height L_y of the lattice's periodic box at the
  density.  The length L_x follows from the area fraction: W L_x = sum_i pi R0,i^2 / density.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .shape import a0_of, radius

__all__ = ["BOUNDARIES", "WALL_CODES", "Confinement", "confinement_of", "boundary_problem", "wall_gap",
           "wall_weights", "wall_rates", "wall_forces", "wall_pressure", "wall_overlap_area", "cell_contours",
           "confinement_of_params"]

#: The boundaries (the ``boundary`` parameter).
BOUNDARIES = ("periodic", "well", "channel")
#: Kernel codes of the walls (``prm[P_WALL]``; 0: periodic, no wall).
WALL_CODES = {"periodic": 0, "well": 1, "channel": 2}
#: Empty margin of the host box beyond a wall, in units of the largest radius (plus the
#: adhesion range): two cells on either side of it are farther apart than any pair the
#: kernels consider (bounding radii <= 1.82 R0,i, plus the list skin and adhesion range).
MARGIN_RADII = 4.0
#: Smallest well radius and channel width, in units of the largest cell radius.
SMALLEST_SIZE = 2.0
#: Largest area fraction a sized well accepts (cells must fit, with room to deform).
MAX_AREA_FRACTION = 0.99


@dataclass(frozen=True)
class Confinement:
    """Where the walls are, in the coordinates of the host box.

    Attributes
    ----------
    kind : str
        ``"well"`` or ``"channel"``.
    size : float
        The well's radius R_w or the channel's width W (length units).
    host : ndarray, shape (2,)
        The periodic host box (Lx, Ly) the kernels and the trajectory use.
    centre : ndarray, shape (2,)
        The well's centre; for a channel, (Lx / 2, (y_lo + y_hi) / 2).
    cell_area : float
        sum_i pi R0,i^2 of the cells it holds.
    """

    kind: str
    size: float
    host: np.ndarray
    centre: np.ndarray
    cell_area: float

    @property
    def code(self) -> int:
        """The kernels' wall code (:data:`WALL_CODES`)."""
        return WALL_CODES[self.kind]

    @property
    def y_lo(self) -> float:
        """Channel: the lower wall (y)."""
        return float(self.centre[1] - 0.5 * self.size)

    @property
    def y_hi(self) -> float:
        """Channel: the upper wall (y)."""
        return float(self.centre[1] + 0.5 * self.size)

    @property
    def area(self) -> float:
        """The area inside the walls: pi R_w^2, or W L_x."""
        return math.pi * self.size ** 2 if self.kind == "well" else self.size * float(self.host[0])

    @property
    def area_fraction(self) -> float:
        """sum_i pi R0,i^2 / :attr:`area`."""
        return self.cell_area / self.area

    @property
    def wall_length(self) -> float:
        """Length of the walls: 2 pi R_w, or 2 L_x (both walls of the channel)."""
        return 2.0 * math.pi * self.size if self.kind == "well" else 2.0 * float(self.host[0])

    @property
    def periodic(self) -> tuple[bool, bool]:
        """Which axes are periodic: (False, False) in a well, (True, False) in a channel."""
        return (False, False) if self.kind == "well" else (True, False)

    def kernel_values(self) -> tuple[float, float, float]:
        """(a, b, c) of the kernels: well (cx, cy, R_w); channel (y_lo, y_hi, 0)."""
        if self.kind == "well":
            return float(self.centre[0]), float(self.centre[1]), float(self.size)
        return self.y_lo, self.y_hi, 0.0

    def inside_distance(self, points) -> np.ndarray:
        """Distance of points (..., 2) from the nearest wall, positive inside
        (``-wall_gap``)."""
        return -wall_gap(points, self)

    def outward_normal(self, points) -> np.ndarray:
        """Unit normal (..., 2) of the nearest wall, pointing out of the confinement."""
        p = np.asarray(points, float)
        if self.kind == "well":
            d = p - self.centre
            r = np.linalg.norm(d, axis=-1, keepdims=True)
            return d / np.where(r > 0, r, 1.0)
        up = p[..., 1] > self.centre[1]
        n = np.zeros(p.shape)
        n[..., 1] = np.where(up, 1.0, -1.0)
        return n

    def random_points(self, n: int, rng: np.random.Generator, inset: float = 0.0) -> np.ndarray:
        """``n`` points uniform in the confinement shrunk by ``inset`` (an initial state)."""
        if self.kind == "well":
            r = (self.size - inset) * np.sqrt(rng.uniform(0.0, 1.0, n))
            t = rng.uniform(0.0, 2.0 * math.pi, n)
            return self.centre + np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
        x = rng.uniform(0.0, 1.0, n) * self.host[0]
        y = self.y_lo + inset + rng.uniform(0.0, 1.0, n) * (self.size - 2.0 * inset)
        return np.stack([x, y], axis=1)


def confinement_of(boundary: str, boundary_size: float, N: int, density: float, R0: float = 1.0, radii=None,
                   reach: float = 0.0) -> Confinement | None:
    """The confinement a run's parameters describe (``None`` for the periodic box).

    Parameters
    ----------
    boundary : str
        One of :data:`BOUNDARIES`.
    boundary_size : float
        The well's radius or the channel's width in R0 (0: from ``density``; see the
        module docstring).
    N : int
        Number of cells.
    density : float
        Area fraction (not used by a well of given radius).
    R0 : float
        The mean radius (length unit).
    radii : array_like, shape (N,), optional
        Per-cell radii (cell size differences).
    reach : float
        Interaction range beyond contact (the adhesion range), added to the margin.
    """
    if boundary == "periodic":
        return None
    if boundary not in BOUNDARIES:
        raise ValueError(f"boundary must be one of {list(BOUNDARIES)}; got {boundary!r}")
    r = np.full(int(N), float(R0)) if radii is None else np.asarray(radii, float).reshape(int(N))
    cell_area = float(math.pi * np.sum(r * r))
    margin = MARGIN_RADII * float(r.max()) + reach
    if boundary == "well":
        Rw = boundary_size * R0 if boundary_size > 0 else math.sqrt(cell_area / (math.pi * density))
        side = 2.0 * (Rw + margin)
        return Confinement("well", Rw, np.array([side, side]), np.array([0.5 * side, 0.5 * side]), cell_area)
    W = boundary_size * R0 if boundary_size > 0 else math.sqrt(cell_area / density * math.sqrt(3.0) / 2.0)
    Lx = cell_area / (density * W)
    Ly = W + 2.0 * margin
    return Confinement("channel", W, np.array([Lx, Ly]), np.array([0.5 * Lx, 0.5 * Ly]), cell_area)


def boundary_problem(boundary: str, boundary_size: float, N: int, density: float, R0: float, r_max: float,
                     initial: str, integrator: str) -> str:
    """Why a confinement cannot run with these settings ("" if it can).

    Confined runs start ``disordered`` (a lattice does not fit a well) and use the Euler
    step (the contact integrators' factors know no wall); the well or channel must be at
    least :data:`SMALLEST_SIZE` largest radii across, and a sized well must hold its cells
    at an area fraction below :data:`MAX_AREA_FRACTION`.
    """
    if boundary == "periodic":
        if boundary_size != 0.0:
            return f"boundary_size = {boundary_size!r} needs boundary 'well' or 'channel' (the box is periodic)"
        return ""
    if boundary not in BOUNDARIES:
        return f"boundary must be one of {list(BOUNDARIES)}; got {boundary!r}"
    if initial != "disordered":
        return (f"boundary = {boundary!r} needs initial: disordered (the hexagonal lattice fills a periodic box); "
                f"got initial = {initial!r}")
    if integrator != "euler":
        return f"boundary = {boundary!r} needs integrator 'euler'; got {integrator!r}"
    size = boundary_size * R0
    if boundary_size > 0 and size < SMALLEST_SIZE * r_max:
        what = "radius" if boundary == "well" else "width"
        return (f"boundary_size = {boundary_size:g} is too small: the {boundary}'s {what} must be at least "
                f"{SMALLEST_SIZE:g} largest cell radii ({SMALLEST_SIZE * r_max / R0:g} R0)")
    if boundary == "well" and boundary_size > 0:
        fraction = N / boundary_size ** 2
        if fraction >= MAX_AREA_FRACTION:
            return (f"a well of radius boundary_size = {boundary_size:g} R0 cannot hold N = {N} cells: area fraction "
                    f"N / boundary_size^2 = {fraction:.3g} (allowed < {MAX_AREA_FRACTION}); use boundary_size > "
                    f"{math.sqrt(N / MAX_AREA_FRACTION):.4g}")
    return ""


def wall_gap(points, conf: Confinement) -> np.ndarray:
    """Signed distance of points (..., 2) outside the confinement (> 0 beyond a wall)."""
    p = np.asarray(points, float)
    if conf.kind == "well":
        return np.linalg.norm(p - conf.centre, axis=-1) - conf.size
    return np.maximum(conf.y_lo - p[..., 1], p[..., 1] - conf.y_hi)


def cell_contours(pos, theta, a, b, R0=1.0, K: int = 40, radii=None):
    """Contour points (N, K, 2) and the radii R, R' (N, K) of every cell.

    ``R0`` is the mean radius; ``radii`` (N,) per-cell radii if sizes differ.
    """
    pos = np.asarray(pos, float).reshape(-1, 2)
    N = len(pos)
    K = int(K)
    phi = 2.0 * np.pi * np.arange(K) / K
    Ri = np.full(N, float(R0)) if radii is None else np.asarray(radii, float).reshape(N)
    a = np.asarray(a, float).reshape(N, -1)
    b = np.asarray(b, float).reshape(N, -1)
    if a.shape[1] == 0:
        R, dR = np.ones((N, K)), np.zeros((N, K))
    else:
        R, dR = radius(phi, a, b, 1.0)
    R, dR = R * Ri[:, None], dR * Ri[:, None]
    ang = np.asarray(theta, float).reshape(N, 1) + phi
    x = pos[:, None, :] + R[..., None] * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    return x, R, dR


def wall_weights(gaps, quadrature: str = "arc") -> np.ndarray:
    """Fraction of each contour point's arc that lies beyond the wall.

    Parameters
    ----------
    gaps : ndarray, shape (..., K)
        :func:`wall_gap` at the contour points (periodic along the last axis).
    quadrature : str
        ``binary``: 1 where the point lies beyond the wall (the paper's rule); ``linear``
        or ``arc``: the fraction of the arc from half-way to the previous point to half-way
        to the next with the gap, interpolated linearly along each segment, positive.

    Returns
    -------
    ndarray, shape (..., K)
        Weights in [0, 1].
    """
    g = np.asarray(gaps, float)
    if quadrature == "binary":
        return (g > 0).astype(float)
    w = np.zeros(g.shape)
    for nb in (np.roll(g, -1, axis=-1), np.roll(g, 1, axis=-1)):
        mid = 0.5 * (g + nb)
        both = (g > 0) & (mid > 0)
        cross = (g > 0) != (mid > 0)
        den = np.where(cross, np.abs(g) + np.abs(mid), 1.0)
        pos_part = np.where(g > 0, g, mid)
        w += np.where(both, 0.5, 0.0) + np.where(cross, 0.5 * pos_part / den, 0.0)
    return w


def _disc_chords(pos, Ri, conf: Confinement) -> np.ndarray:
    """Rigid discs: the chord vector (N, 2) of each disc's part beyond the wall, pointing
    out of the confinement (the gradient of that part's area)."""
    pos = np.asarray(pos, float)
    out = np.zeros(pos.shape)
    if conf.kind == "well":
        d = pos - conf.centre
        D = np.linalg.norm(d, axis=1)
        Rw = conf.size
        hit = (D + Ri > Rw) & (D > 0) & (D < Rw + Ri) & (D > np.abs(Rw - Ri))
        x = np.where(hit, (D * D + Rw * Rw - Ri * Ri) / (2.0 * np.where(hit, D, 1.0)), 0.0)
        h = np.sqrt(np.maximum(Rw * Rw - x * x, 0.0))
        out[hit] = (2.0 * h[hit] / D[hit])[:, None] * d[hit]
        return out
    for wall, sign in ((conf.y_lo, -1.0), (conf.y_hi, 1.0)):
        depth = sign * (pos[:, 1] - wall)  # > -Ri: the disc crosses this wall
        hc = np.sqrt(np.maximum(Ri * Ri - np.minimum(depth, Ri) ** 2, 0.0))
        crosses = (depth > -Ri) & (depth < Ri)
        out[crosses, 1] += sign * 2.0 * hc[crosses]
    return out


def wall_rates(pos, theta, a, b, conf: Confinement, *, R0=1.0, contour_points=40, quadrature="arc",
               mu_theta=1.0, mu_shape=1.0, radii=None) -> dict:
    """The rates the wall energy gives every cell (reference of the numba kernel).

    Parameters
    ----------
    pos, theta, a, b : array_like
        Cell state in the host box's coordinates ((N, 2), (N,), (N, M-1), (N, M-1)).
    conf : Confinement
    R0, contour_points, quadrature, mu_theta, mu_shape, radii
        As for :func:`fcsweep.model.rates.rates`.

    Returns
    -------
    dict
        ``dpos`` (N, 2), ``dtheta`` (N,), ``da``, ``db`` (N, M-1): -mobility x gradient of
        :func:`wall_overlap_area` under the rule ``quadrature``.
    """
    pos = np.asarray(pos, float).reshape(-1, 2)
    N = len(pos)
    a = np.asarray(a, float).reshape(N, -1)
    b = np.asarray(b, float).reshape(N, -1)
    Ri = np.full(N, float(R0)) if radii is None else np.asarray(radii, float).reshape(N)
    if a.shape[1] == 0:
        return {"dpos": -_disc_chords(pos, Ri, conf), "dtheta": np.zeros(N), "da": a * 0.0, "db": b * 0.0}
    K = int(contour_points)
    x, R, dR = cell_contours(pos, theta, a, b, R0, K, radii)
    w = wall_weights(wall_gap(x, conf), quadrature)
    dphi = 2.0 * np.pi / K
    phi = 2.0 * np.pi * np.arange(K) / K
    ang = np.asarray(theta, float).reshape(N, 1) + phi
    e = np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    eperp = np.stack([-np.sin(ang), np.cos(ang)], axis=-1)
    dpos = np.sum(w[..., None] * (dR[..., None] * eperp - R[..., None] * e), axis=1) * dphi
    dtheta = mu_theta * np.sum(w * R * dR, axis=1) * dphi
    n = np.arange(2, a.shape[1] + 2)
    a0 = a0_of(a, b)[:, None]
    cos_n = np.cos(np.multiply.outer(n, phi))  # (M1, K)
    sin_n = np.sin(np.multiply.outer(n, phi))
    wR = w * R * dphi
    usum = wR.sum(axis=1)[:, None]
    da = -mu_shape * Ri[:, None] * (wR @ cos_n.T - a / (2.0 * a0) * usum)
    db = -mu_shape * Ri[:, None] * (wR @ sin_n.T - b / (2.0 * a0) * usum)
    return {"dpos": dpos, "dtheta": dtheta, "da": da, "db": db}


def wall_forces(pos, theta, a, b, conf: Confinement, *, R0=1.0, contour_points=40, quadrature="arc",
                radii=None) -> np.ndarray:
    """Force (N, 2) of the wall on every cell: -d E_wall / d r_i (the centroid rate at unit
    mobility), under the rule ``quadrature`` (:func:`wall_rates`)."""
    return wall_rates(pos, theta, a, b, conf, R0=R0, contour_points=contour_points, quadrature=quadrature,
                      radii=radii)["dpos"]


def wall_pressure(pos, theta, a, b, conf: Confinement, *, R0=1.0, contour_points=40, quadrature="arc",
                  radii=None) -> float:
    """The pressure on the wall: the inward-normal components of the wall forces summed
    over cells, per unit wall length (energy per area: the units of the overlap term).

    Each cell's force is projected on the wall's inward normal at the cell's centre (the
    wall's force on a cell points inward; the cells push the wall outward as hard).
    """
    F = wall_forces(pos, theta, a, b, conf, R0=R0, contour_points=contour_points, quadrature=quadrature,
                    radii=radii)
    n = conf.outward_normal(np.asarray(pos, float).reshape(-1, 2))
    return float(-np.sum(F * n)) / conf.wall_length


def wall_overlap_area(pos, theta, a, b, conf: Confinement, *, R0=1.0, points: int = 8192, radii=None) -> np.ndarray:
    """Area of each cell beyond the wall, E_wall per cell (N,), by quadrature over the
    contour angle: A = 1/2 int max(R(phi)^2 - s(phi)^2, 0) dphi, with s(phi) the distance
    from the cell's centre to the wall along the ray at phi (centres inside; the ray meets
    the wall once).  The trapezoidal rule on ``points`` angles: errors ~ (2 pi / points)^2
    at the kinks where the contour crosses the wall.
    """
    pos = np.asarray(pos, float).reshape(-1, 2)
    N = len(pos)
    a = np.asarray(a, float).reshape(N, -1)
    b = np.asarray(b, float).reshape(N, -1)
    _, R, _ = cell_contours(pos, theta, a, b, R0, points, radii)
    phi = 2.0 * np.pi * np.arange(points) / points
    ang = np.asarray(theta, float).reshape(N, 1) + phi
    u = np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    if conf.kind == "well":
        d = pos[:, None, :] - conf.centre
        du = np.sum(d * u, axis=-1)
        dd = np.sum(d * d, axis=-1)
        s = -du + np.sqrt(np.maximum(du * du - dd + conf.size ** 2, 0.0))
    else:
        uy = u[..., 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            s_up = np.where(uy > 0, (conf.y_hi - pos[:, 1:2]) / uy, np.inf)
            s_dn = np.where(uy < 0, (conf.y_lo - pos[:, 1:2]) / uy, np.inf)
        s = np.minimum(s_up, s_dn)
    integrand = np.where(R > s, 0.5 * (R * R - np.minimum(s, R) ** 2), 0.0)
    return integrand.sum(axis=1) * (2.0 * np.pi / points)


def confinement_of_params(params, radii=None) -> Confinement | None:
    """:func:`confinement_of` for a run's parameters (a mapping of the parameter table;
    missing keys take their defaults), ``None`` for a periodic run.

    Parameters
    ----------
    params : mapping
        Run parameters (``boundary``, ``boundary_size``, ``N``, ``density``, ``R0``,
        ``adhesion``, ``adhesion_range``).
    radii : array_like, shape (N,), optional
        Per-cell radii when sizes differ (``particles/cells/R0`` of a trajectory).
    """
    boundary = str(params.get("boundary", "periodic"))
    if boundary == "periodic":
        return None
    R0 = float(params.get("R0", 1.0))
    reach = float(params.get("adhesion_range", 0.1)) * R0 if float(params.get("adhesion", 0.0)) > 0 else 0.0
    return confinement_of(boundary, float(params.get("boundary_size", 0.0)), int(params["N"]),
                          float(params.get("density", 0.95)), R0, radii, reach)
