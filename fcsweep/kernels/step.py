"""Euler-Maruyama integration of the contour model (numba).

The deterministic rates are those of explicit Euler, or, with ``prm[P_CONTACT] > 0``, the
effective rates of the contact-implicit step (each pair's integrals scaled by its
implicit factor, :mod:`fcsweep.kernels.contacts`), or, with ``prm[P_SWEEPS] > 0`` as well,
those of the contact-jacobi step (the factors solved with each contact's approach rate,
:func:`fcsweep.kernels.rates.contact_sweeps`); the update and the noise are the same.

The noise for all steps of a chunk is drawn by the caller from a numpy Generator and
passed in, so a run is determined by its parameters and seed, and a chunked or resumed
run reproduces an uninterrupted one bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .adhesion import adhesion_rates
from .celllist import build_cell_list, grid_shape
from .geometry import geometry
from .options import NJIT, njit
from .pairs import QUAD_ARC
from .rates import all_rates, contact_sweeps
from .records import P_ADH, P_ADHR, P_DMAX, P_DT, P_LX, P_LY, P_NOISE, P_R0, P_SKIN, P_SMAX, P_SWEEPS, P_WALL
from .verlet import build_back, build_verlet, needs_rebuild
from .walls import wall_rates

#: Status codes returned by :func:`run_chunk`.
OK = 0
NONFINITE = 1
TOO_FAST = 2
LIST_FULL = 3



@njit(parallel=True, **NJIT)
def euler_update(pos, image, theta, a, b, out, noise, prm, periodic, flags):
    """One Euler-Maruyama update with the rates ``out``; project shapes beyond
    ``prm[P_SMAX]``; flag bad cells.

    ``flags[i]``: bit 1 non-finite, bit 2 displacement above ``prm[P_DMAX]``, bit 4 projected.
    """
    dpos, dth, da, db = out
    Lx = prm[P_LX]
    Ly = prm[P_LY]
    dt = prm[P_DT]
    noise_amp = prm[P_NOISE]
    smax = prm[P_SMAX]
    dmax = prm[P_DMAX]
    N, M1 = a.shape
    for i in prange(N):
        f = 0
        vx = dpos[i, 0]
        vy = dpos[i, 1]
        if not (math.isfinite(vx) and math.isfinite(vy) and math.isfinite(dth[i])):
            f |= 1
        if dt * math.sqrt(vx * vx + vy * vy) > dmax:
            f |= 2
        x = pos[i, 0] + dt * vx
        y = pos[i, 1] + dt * vy
        if periodic:
            sx = math.floor(x / Lx)
            sy = math.floor(y / Ly)
            if sx != 0.0:
                x -= sx * Lx
                image[i, 0] += np.int64(sx)
            if sy != 0.0:
                y -= sy * Ly
                image[i, 1] += np.int64(sy)
            # floating round-off can leave x == Lx after the shift
            if x >= Lx:
                x -= Lx
                image[i, 0] += 1
            if y >= Ly:
                y -= Ly
                image[i, 1] += 1
        pos[i, 0] = x
        pos[i, 1] = y
        theta[i] += dt * dth[i] + noise_amp * noise[i]
        s1 = 0.0
        for m in range(M1):
            a[i, m] += dt * da[i, m]
            b[i, m] += dt * db[i, m]
            s1 += math.sqrt(a[i, m] * a[i, m] + b[i, m] * b[i, m])
        if not math.isfinite(s1):
            f |= 1
        elif s1 > smax:
            scale = smax / s1
            for m in range(M1):
                a[i, m] *= scale
                b[i, m] *= scale
            f |= 4
        flags[i] = f


@njit(**NJIT)
def compute_rates(pos, theta, a, b, prm, periodic, quad, tables, scratch, cl, nl, out):
    """Geometry, neighbour list and rates for the current state (helper of run_chunk).

    Returns False if the neighbour list overflowed (the caller enlarges it and calls
    again; nothing has been changed but scratch).
    """
    geo = scratch.geo
    cell_of, cell_start, cell_members = cl
    nbr, count, ref_pos, ref_rb, valid, _, _, pinfo, back = nl
    geometry(theta, a, b, prm[P_R0], tables, scratch, quad == QUAD_ARC)
    Lx = prm[P_LX]
    Ly = prm[P_LY]
    skin = prm[P_SKIN]
    # the list reaches the adhesion range beyond the skin (0 when adhesion is off)
    reach = skin + prm[P_ADHR]
    use_list = False
    if periodic:
        rbmax = 0.0
        for i in range(pos.shape[0]):
            rbmax = max(rbmax, geo[i, 1])
        nx, ny = grid_shape(Lx, Ly, 2.0 * rbmax + reach, pos.shape[0])
        if nx >= 3 and ny >= 3 and (nx * ny + 1) <= cell_start.shape[0]:
            use_list = True
            if valid[0] == 0 or needs_rebuild(pos, geo, ref_pos, ref_rb, Lx, Ly, skin):
                build_cell_list(pos, Lx, Ly, nx, ny, cell_of, cell_start, cell_members)
                valid[0] = 0
                if not build_verlet(pos, geo, Lx, Ly, reach, nx, ny, cell_of, cell_start, cell_members,
                                    nbr, count, ref_pos, ref_rb):
                    return False
                if back.shape[0] > 0:
                    build_back(nbr, count, back)
                valid[0] = 1
        else:
            valid[0] = 0
    sweeps = np.int64(prm[P_SWEEPS])
    jacobi = sweeps > 0 and use_list and quad == QUAD_ARC and a.shape[1] > 0 and pinfo.shape[0] > 0
    all_rates(pos, a, b, prm, periodic, quad, tables, scratch, nl, out, use_list, jacobi)
    if prm[P_ADH] > 0.0:
        adhesion_rates(pos, a, b, prm, periodic, tables, scratch, nl, out, use_list)
    if prm[P_WALL] > 0.0:
        wall_rates(pos, a, b, prm, quad, tables, scratch, out)
    if jacobi:
        contact_sweeps(a, b, prm, scratch, nl, out, sweeps)
    return True


@njit(**NJIT)
def run_chunk(pos, image, theta, a, b, noise, prm, periodic, quad, tables, scratch, cl, nl, out, flags):
    """Advance ``noise.shape[0]`` steps; stop early at the first bad step.

    Returns
    -------
    steps_done : int
    status : int
        OK; NONFINITE or TOO_FAST (the state is left at the bad step); or
        LIST_FULL (the step was not taken: enlarge the neighbour list and go on).
    projections : int
        Admissibility projections during the chunk.
    """
    nproj = 0
    for step in range(noise.shape[0]):
        if not compute_rates(pos, theta, a, b, prm, periodic, quad, tables, scratch, cl, nl, out):
            return step, LIST_FULL, nproj
        euler_update(pos, image, theta, a, b, out, noise[step], prm, periodic, flags)
        worst = 0
        for i in range(flags.shape[0]):
            f = flags[i]
            if f & 4:
                nproj += 1
            worst |= f
        if worst & 1:
            return step + 1, NONFINITE, nproj
        if worst & 2:
            return step + 1, TOO_FAST, nproj
    return noise.shape[0], OK, nproj
