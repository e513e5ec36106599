"""Synthetic data with known answers for the statistics tests (not part of the package).

- :func:`ar1`: AR(1) series, integrated autocorrelation time ``(1 + phi) / (1 - phi)``.
- :func:`abp_positions`: free or harmonically caged active Brownian particles,
  exact in distribution for the free ones (Euler steps much shorter than 1/Dr and 1/k).
- :func:`collective_positions`: cells moved by a few box-wide displacement modes with
  random-walk amplitudes, plus independent thermal noise.
- :func:`triangular_crystal`, :func:`random_sequential_discs`, :func:`aligned_mosaic`:
  KTHNY solid, liquid and hexatic-like configurations.
- :func:`harmonic_crystal`, :func:`harmonic_cg1`: a triangular lattice with a Gaussian
  c/k^2 displacement field (first-shell exponent eta_G1 known exactly) and its exact C_G1(r).
"""

import numpy as np
from scipy.signal import lfilter


def ar1(phi, n, rng, x0=None):
    """AR(1) series ``x_t = phi x_{t-1} + eps_t``, started stationary (or at ``x0``)."""
    e = rng.normal(size=n)
    e[0] = e[0] / np.sqrt(1 - phi ** 2) if x0 is None else x0
    return lfilter([1.0], [1.0, -phi], e)


def abp_positions(n_particles, n_frames, frame_dt, *, v0, Dr, k=0.0, substeps=10, rng):
    """Unwrapped positions (n_frames, n_particles, 2) of ABPs, free (k = 0) or in harmonic cages.

    Integrated with ``substeps`` Euler steps per frame (the cage relaxation exp(-k h) and
    the rotational diffusion are exact per sub-step); cages start at the stationary
    spread so no transient is left.
    """
    h = frame_dt / substeps
    theta = rng.uniform(0, 2 * np.pi, n_particles)
    site = rng.uniform(0, 50, (n_particles, 2))
    r = np.zeros((n_particles, 2))
    if k > 0:  # burn in 20 slowest relaxation times
        burn = int(20 * max(1 / k, 1 / Dr) / h)
        for _ in range(burn):
            r += h * (v0 * np.stack([np.cos(theta), np.sin(theta)], 1) - k * r)
            theta += np.sqrt(2 * Dr * h) * rng.normal(size=n_particles)
    out = np.empty((n_frames, n_particles, 2))
    for f in range(n_frames):
        out[f] = site + r
        for _ in range(substeps):
            r += h * (v0 * np.stack([np.cos(theta), np.sin(theta)], 1) - k * r)
            theta += np.sqrt(2 * Dr * h) * rng.normal(size=n_particles)
    return out


def collective_positions(n_side, n_frames, *, modes=4, amp_step=0.3, noise=0.02, rng):
    """Cells on an n_side x n_side square lattice (box n_side) moved by collective modes.

    Displacement of cell i at frame t: ``sum_m A_m(t) * e_m * cos(k_m . x_i + phi_m)``
    with random-walk amplitudes ``A_m`` (steps ``amp_step``), wave vectors of the box and
    random polarisations ``e_m``, plus an independent random walk of step ``noise`` per
    cell. Returns unwrapped positions (n_frames, n_side**2, 2).
    """
    g = np.arange(n_side) + 0.5
    X = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    N = len(X)
    kk = 2 * np.pi / n_side * rng.integers(1, 3, size=(modes, 2)) * rng.choice([-1, 1], size=(modes, 2))
    phase = rng.uniform(0, 2 * np.pi, modes)
    ang = rng.uniform(0, 2 * np.pi, modes)
    e = np.stack([np.cos(ang), np.sin(ang)], -1)
    shape = np.cos(X @ kk.T + phase)  # (N, modes)
    A = np.cumsum(rng.normal(scale=amp_step, size=(n_frames, modes)), axis=0)
    own = np.cumsum(rng.normal(scale=noise, size=(n_frames, N, 2)), axis=0)
    disp = np.einsum("tm,nm,md->tnd", A, shape, e)
    return X[None] + disp + own


def triangular_crystal(n, jitter, rng, a=1.0):
    """n x n triangular lattice (spacing a) with independent Gaussian jitter (sd jitter * a),
    wrapped into its periodic box; returns (positions, box)."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    pos = np.stack([((i + 0.5 * (j % 2)) * a).ravel(), (j * a * np.sqrt(3) / 2).ravel()], 1)
    box = (n * a, n * a * np.sqrt(3) / 2)
    return np.mod(pos + rng.normal(scale=jitter * a, size=pos.shape), box), box


def random_sequential_discs(n, area_fraction, rng, radius=0.5):
    """Random sequential addition of n non-overlapping discs in a periodic square box at the
    given area fraction (below the jamming limit 0.547); returns (positions, box)."""
    L = np.sqrt(n * np.pi * radius ** 2 / area_fraction)
    pts = np.empty((0, 2))
    while len(pts) < n:
        for p in rng.uniform(0, L, (256, 2)):
            if len(pts) == n:
                break
            d = p - pts
            d -= L * np.round(d / L)
            if len(pts) == 0 or np.min(np.einsum("ij,ij->i", d, d)) >= 4 * radius ** 2:
                pts = np.vstack([pts, p])
    return pts, (L, L)


def aligned_mosaic(n, domain, rng, *, tilt=0.03, jitter=0.05, a=1.0, random_orientation=False):
    """Hexatic-like configuration: the box of an n x n triangular lattice cut into periodic
    Voronoi domains (about ``domain`` spacings across), each filled with a triangular
    lattice of one common orientation (+- ``tilt`` rad, Gaussian) but its own random
    offset, then jittered (sd ``jitter * a``); of two cells closer than 0.7 a across a
    domain wall one is dropped. Bond order stays long-ranged, translational order dies
    over a domain. With ``random_orientation`` each domain's lattice is turned by its own
    uniform angle about the domain's seed: a polycrystal, whose bond order dies over a
    domain too. Returns (positions, box)."""
    from scipy.spatial import cKDTree

    L = np.array([n * a, n * a * np.sqrt(3) / 2])
    seeds = rng.uniform(0, 1, (max(1, int(round(L.prod() / domain ** 2))), 2)) * L
    owner = cKDTree(seeds, boxsize=L)
    lo, hi = (-n - 2, 2 * n + 3) if random_orientation else (-2, n + 3)
    i, j = np.meshgrid(np.arange(lo, hi), np.arange(lo, hi), indexing="ij")
    base = np.stack([(i + 0.5 * (j % 2)).ravel(), (j * np.sqrt(3) / 2).ravel()], 1) * a
    parts = []
    for k in range(len(seeds)):
        th = rng.uniform(0, np.pi / 3) if random_orientation else rng.normal(scale=tilt)
        R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        c = seeds[k] if random_orientation else np.zeros(2)
        p = (base - c) @ R.T + c + rng.uniform(0, a, 2)
        p = p[np.all((p >= 0) & (p < L), axis=1)]
        parts.append(p[owner.query(p)[1] == k])
    p = np.concatenate(parts)
    p = np.mod(p + rng.normal(scale=jitter * a, size=p.shape), L)
    keep = np.ones(len(p), bool)
    for u, v in sorted(cKDTree(p, boxsize=L).query_pairs(0.7 * a)):
        if keep[u] and keep[v]:
            keep[v] = False
    return p[keep], (float(L[0]), float(L[1]))


def creeping_lattice(D, rng, *, n_side=16, area_fraction=0.95, R0=1.0, jitter=0.1, tau_jitter=50.0,
                     frame_dt=10.0, span=30000.0, gaussian=False):
    """A creeping solid / slow fluid: ``n_side**2`` cells at the sites of a triangular
    lattice of area fraction ``area_fraction`` (cells of radius R0; spacing
    ``a = (2 pi R0^2 / (sqrt(3) area_fraction))^(1/2)``), each jittering about its site
    (Ornstein-Uhlenbeck, sd ``jitter * R0`` per axis, relaxation time ``tau_jitter``) and
    hopping by one spacing ``a`` in a random direction at Poisson times of rate
    ``4 D / a^2`` (independently of its neighbours), so that its long-time
    self-diffusion coefficient is ``D``. Frames every ``frame_dt`` over ``span``. With
    ``gaussian`` the cells creep by Brownian steps of the same ``D`` instead of hops (a
    fluid whose displacements are Gaussian).

    Returns
    -------
    time : ndarray, shape (T,)
    unwrapped : ndarray, shape (T, n_side**2, 2)
    box : (Lx, Ly)
    """
    a = float(np.sqrt(2.0 * np.pi * R0 ** 2 / (np.sqrt(3.0) * area_fraction)))
    i, j = np.meshgrid(np.arange(n_side), np.arange(n_side), indexing="ij")
    sites = np.stack([((i + 0.5 * (j % 2)) * a).ravel(), (j * a * np.sqrt(3) / 2).ravel()], 1)
    box = (n_side * a, n_side * a * np.sqrt(3) / 2)
    T = int(round(span / frame_dt)) + 1
    N = sites.shape[0]
    if gaussian:
        steps = rng.normal(scale=np.sqrt(2.0 * D * frame_dt), size=(T - 1, N, 2))
    else:
        hops = rng.poisson(4.0 * D / a ** 2 * frame_dt, size=(T - 1, N))
        steps = np.zeros((T - 1, N, 2))
        for n in range(1, int(hops.max(initial=0)) + 1):  # each hop its own random direction
            ang = rng.uniform(0, 2 * np.pi, size=(T - 1, N))
            steps += (hops >= n)[..., None] * a * np.stack([np.cos(ang), np.sin(ang)], -1)
    walk = np.concatenate([np.zeros((1, N, 2)), np.cumsum(steps, axis=0)])
    f = np.exp(-frame_dt / tau_jitter)
    sd = jitter * R0
    noise = rng.normal(scale=sd * np.sqrt(1 - f * f), size=(T, N, 2))
    noise[0] = rng.normal(scale=sd, size=(N, 2))
    u = lfilter([1.0], [1.0, -f], noise, axis=0)
    return np.arange(T) * frame_dt, sites[None] + walk + u, box


G1A = 4 * np.pi / np.sqrt(3)  # |G1| a of a triangular lattice


def _harmonic_modes(n, a):
    """Sites (N, 2), box and the box's modes k (M, 2) at the sites, k = 0 left out.

    The modes are ``k = 2 pi (m / Lx, l / Ly)`` with ``m, l`` in ``[-n/2, n/2)``: n^2 - 1 of
    them, one per Bloch vector of the lattice (a zone of the area of the Brillouin zone)."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    sites = np.stack([((i + 0.5 * (j % 2)) * a).ravel(), (j * a * np.sqrt(3) / 2).ravel()], 1)
    box = (n * a, n * a * np.sqrt(3) / 2)
    m = np.arange(-n // 2, n // 2)
    k = np.stack(np.meshgrid(m, m, indexing="ij"), -1).reshape(-1, 2) * (2 * np.pi / np.array(box))
    return sites, box, k[np.any(k != 0, axis=1)]


def harmonic_c(eta_G1, n, a=1.0):
    """Spectrum amplitude c of :func:`harmonic_crystal` for a first-shell exponent eta_G1."""
    area = n * a * n * a * np.sqrt(3) / 2
    return 4 * np.pi * eta_G1 / ((G1A / a) ** 2 * area)


def harmonic_crystal(n, eta_G1, rng, frames=1, a=1.0):
    """Triangular n x n lattice (n even) in its periodic box plus a Gaussian displacement
    field with a c/k^2 spectrum, the harmonic crystal of first-shell exponent ``eta_G1``.

    Convention: ``u_i = sum_k [A_k cos(k . R_i) + B_k sin(k . R_i)]`` over the box modes k
    of :func:`_harmonic_modes` (both signs of k, each independently), with ``A_k``, ``B_k``
    isotropic Gaussian 2-vectors of variance ``c / (2 k^2)`` per component, i.e.
    ``<|u_k . e|^2> = <(A_k . e)^2 + (B_k . e)^2> = c / k^2`` for both polarisations e.
    For a unit vector ``G^`` and ``d = R_j - R_i``, each mode adds
    ``(c / (2 k^2)) [(cos k.R_j - cos k.R_i)^2 + (sin k.R_j - sin k.R_i)^2] = (c / k^2)(1 - cos k.d)``
    to the variance of ``G^ . (u_j - u_i)``, so

        D(d) = <(G^ . (u_j - u_i))^2> = sum_k (c / k^2) (1 - cos k . d)

    exactly, and since ``G1 . d`` is a multiple of 2 pi and the field Gaussian,
    ``C_G1(d) = <cos G1 . (d + u_j - u_i)> = exp(-G1^2 D(d) / 2)``.  In the continuum
    ``sum_k -> A / (2 pi)^2 int d^2k`` and ``int d^2k (1 - cos k.d) / k^2 = 2 pi ln(d) + const``,
    so ``D = (c A / (2 pi)) ln d + const`` and ``C_G1 ~ d^(-eta_G1)`` with
    ``eta_G1 = G1^2 c A / (4 pi)`` (A the box area, ``G1 = 4 pi / (sqrt(3) a)``).

    Returns
    -------
    list of (positions, box)
        ``frames`` independent configurations, positions wrapped into the box.
    """
    sites, box, k = _harmonic_modes(n, a)
    c = harmonic_c(eta_G1, n, a)
    sd = np.sqrt(c / (2 * np.sum(k * k, axis=1)))
    ph = sites @ k.T
    cos, sin = np.cos(ph), np.sin(ph)
    out = []
    for _ in range(frames):
        A = rng.normal(size=(k.shape[0], 2)) * sd[:, None]
        B = rng.normal(size=(k.shape[0], 2)) * sd[:, None]
        out.append((np.mod(sites + cos @ A + sin @ B, box), box))
    return out


def harmonic_cg1(n, eta_G1, dr, r_max, a=1.0):
    """Exact C_G1(r) of :func:`harmonic_crystal`, binned like ``order.shell_correlation``:
    the mean of ``exp(-G1^2 D(d) / 2)`` over the lattice vectors d (minimum image, each
    once per site, as the pairs are) with ``|d|`` in the bin (the bins of the measured
    curve hold the displaced separations; the difference is a smearing within a bin)."""
    sites, box, k = _harmonic_modes(n, a)
    L = np.array(box)
    d = sites - sites[0]
    d -= L * np.round(d / L)
    c = harmonic_c(eta_G1, n, a)
    w = c / np.sum(k * k, axis=1)
    D = np.array([np.sum(w * (1 - np.cos(k @ x))) for x in d])
    C = np.exp(-0.5 * (G1A / a) ** 2 * D)
    nb = int(np.floor(r_max / dr + 1e-9))
    r = (np.arange(nb) + 0.5) * dr
    idx = (np.hypot(d[:, 0], d[:, 1]) / dr).astype(int)
    keep = (idx < nb) & (idx > 0)
    s = np.bincount(idx[keep], weights=C[keep], minlength=nb)
    m = np.bincount(idx[keep], minlength=nb)
    with np.errstate(invalid="ignore"):
        return r, np.where(m > 0, s / m, np.nan)
