"""Compiled per-cell pixel work of the shape estimators (:mod:`fcsweep.measure.cells`,
:mod:`fcsweep.measure.perimeter`), each giving the answer of the library operation it replaces
without its per-call cost (a dozen such calls per cell were most of the estimators' cost):
the Gaussian blur of a mask and the arc-length resampling of an outline (bit for bit
``scipy.ndimage.gaussian_filter`` and ``np.interp``: they repeat their operation order), the
boundary pixels attached to their nearest outline sample, the split and sliver tests, the
band of mixed pixels, and the weighted least-squares Fourier fit of an outline (its normal
equations where well conditioned).  tests/test_measure_kernels.py checks each against the
library.  Compiled with numba (cached next to this module, or in numba's user-wide cache
where that is not writable).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["edge_pixels", "mixed_pixels", "pieces_and_fit", "radius_fit", "resample", "blurred_mask"]


@numba.njit(cache=True, error_model="numpy")
def edge_pixels(mask, p):
    """The boundary pixel centres of a cell, attached to the outline: ``(pts, side, at)``.

    ``pts`` (N, 2) holds the centres of the mask's pixels with a 4-neighbour outside it
    (``side`` True) and of those outside it with a 4-neighbour in it (``side`` False), pixel
    ``(r, c)`` at ``(c, r)``; ``at`` is the index of the nearest point of ``p`` (K, 2), the
    lowest index on a tie.  Sorted by ``at`` (stable: inside before outside, row by row)."""
    H, W = mask.shape
    # nearest sample of every pixel centre within 2 px of one (pixel (r, c) of the mask at [r + 1, c + 1])
    best = np.full((H + 2, W + 2), np.inf)
    idx = np.full((H + 2, W + 2), -1, np.int64)
    for s in range(p.shape[0]):
        x, y = p[s, 0], p[s, 1]
        c0, c1 = max(int(np.ceil(x - 2.0)), -1), min(int(np.floor(x + 2.0)), W)
        r0, r1 = max(int(np.ceil(y - 2.0)), -1), min(int(np.floor(y + 2.0)), H)
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                d = (c - x) ** 2 + (r - y) ** 2
                if d < best[r + 1, c + 1]:
                    best[r + 1, c + 1] = d
                    idx[r + 1, c + 1] = s
    n_in = 0
    n_out = 0
    kind = np.zeros((H + 2, W + 2), np.int8)
    for r in range(-1, H + 1):
        for c in range(-1, W + 1):
            here = 0 <= r < H and 0 <= c < W and mask[r, c]
            nb_in = False
            nb_out = False
            for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                rr, cc = r + dr, c + dc
                v = 0 <= rr < H and 0 <= cc < W and mask[rr, cc]
                nb_in = nb_in or v
                nb_out = nb_out or not v
            if here and nb_out:
                kind[r + 1, c + 1] = 1
                n_in += 1
            elif not here and nb_in:
                kind[r + 1, c + 1] = 2
                n_out += 1
    pts = np.empty((n_in + n_out, 2))
    side = np.empty(n_in + n_out, np.bool_)
    at = np.empty(n_in + n_out, np.int64)
    k_in = 0
    k_out = n_in
    for r in range(-1, H + 1):
        for c in range(-1, W + 1):
            kd = kind[r + 1, c + 1]
            if kd == 0:
                continue
            k = k_in if kd == 1 else k_out
            pts[k, 0], pts[k, 1], side[k] = c, r, kd == 1
            s = idx[r + 1, c + 1]
            if s < 0 or best[r + 1, c + 1] > 4.0:  # no sample within 2 px: all of them
                bd = np.inf
                for q in range(p.shape[0]):
                    d = (c - p[q, 0]) ** 2 + (r - p[q, 1]) ** 2
                    if d < bd:
                        bd, s = d, q
            at[k] = s
            if kd == 1:
                k_in += 1
            else:
                k_out += 1
    # stable counting sort by the attached sample
    first = np.zeros(p.shape[0] + 1, np.int64)
    for k in range(at.size):
        first[at[k] + 1] += 1
    for s in range(p.shape[0]):
        first[s + 1] += first[s]
    order = np.empty(at.size, np.int64)
    for k in range(at.size):
        order[first[at[k]]] = k
        first[at[k]] += 1
    return pts[order], side[order], at[order]


@numba.njit(cache=True, error_model="numpy")
def mixed_pixels(mask, half):
    """(rows, cols) of the pixels of ``mask`` whose (2 half + 1)-square about them (zero outside
    the array) holds pixels both in and out of the mask, row by row."""
    H, W = mask.shape
    S = np.zeros((H + 1, W + 1), np.int64)
    for r in range(H):
        for c in range(W):
            S[r + 1, c + 1] = S[r, c + 1] + S[r + 1, c] - S[r, c] + (1 if mask[r, c] else 0)
    full = (2 * half + 1) ** 2
    sel = np.zeros((H, W), np.bool_)
    m = 0
    for r in range(H):
        r0, r1 = max(r - half, 0), min(r + half + 1, H)
        for c in range(W):
            c0, c1 = max(c - half, 0), min(c + half + 1, W)
            k = S[r1, c1] - S[r0, c1] - S[r1, c0] + S[r0, c0]
            if 0 < k < full:
                sel[r, c] = True
                m += 1
    rows = np.empty(m, np.int64)
    cols = np.empty(m, np.int64)
    m = 0
    for r in range(H):
        for c in range(W):
            if sel[r, c]:
                rows[m], cols[m] = r, c
                m += 1
    return rows, cols


@numba.njit(cache=True, error_model="numpy")
def pieces_and_fit(mask, disc):
    """``(pieces, fits)``: whether the mask's pixels form more than one 8-connected piece, and
    whether the structuring element ``disc`` (odd square, centred) fits inside the mask."""
    H, W = mask.shape
    seen = np.zeros((H, W), np.bool_)
    stack = np.empty(H * W, np.int64)
    pieces = 0
    for r in range(H):
        for c in range(W):
            if not mask[r, c] or seen[r, c]:
                continue
            pieces += 1
            if pieces > 1:
                break
            seen[r, c] = True
            top = 0
            stack[0] = r * W + c
            top = 1
            while top:
                top -= 1
                rr, cc = divmod(stack[top], W)
                for dr in range(-1, 2):
                    for dc in range(-1, 2):
                        r2, c2 = rr + dr, cc + dc
                        if 0 <= r2 < H and 0 <= c2 < W and mask[r2, c2] and not seen[r2, c2]:
                            seen[r2, c2] = True
                            stack[top] = r2 * W + c2
                            top += 1
        if pieces > 1:
            break
    h = disc.shape[0] // 2
    fits = False
    for r in range(h, H - h):
        for c in range(h, W - h):
            if not mask[r, c]:
                continue
            ok = True
            for dr in range(-h, h + 1):
                for dc in range(-h, h + 1):
                    if disc[dr + h, dc + h] and not mask[r + dr, c + dc]:
                        ok = False
                        break
                if not ok:
                    break
            if ok:
                fits = True
                break
        if fits:
            break
    return pieces > 1, fits


@numba.njit(cache=True, error_model="numpy")
def radius_fit(x, y, modes, star_tolerance, ct, st):
    """The weighted least-squares fit of ``R(phi)`` of :func:`fcsweep.measure.cells.fit_radius`:
    ``(coef, perimeter, area, star)``, the fitted curve evaluated through ``ct[n - 1, i] =
    cos(n t_i)``, ``st`` likewise, at equally spaced ``t_i`` over one turn."""
    K = x.size
    phi = np.arctan2(y, x)
    r = np.hypot(x, y)
    turn = 0.0
    dphi = np.empty(K)
    for i in range(K):
        d = phi[(i + 1) % K] - phi[i]
        dphi[i] = np.arctan2(np.sin(d), np.cos(d))
        turn += dphi[i]
    sgn = 1.0 if turn > 0 else (-1.0 if turn < 0 else 0.0)
    back = 0.0
    for i in range(K):
        back -= min(sgn * dphi[i], 0.0)
    star = abs(abs(turn) - 2 * np.pi) < 1e-6 and back < star_tolerance
    n_par = 2 * modes + 1
    coef = np.full(n_par, np.nan)
    if K < n_par + 2:
        return coef, np.nan, np.nan, star
    seg = np.empty(K)
    for i in range(K):
        j = (i + 1) % K
        seg[i] = np.hypot(x[j] - x[i], y[j] - y[i])
    design = np.empty((K, n_par))
    rhs = np.empty(K)
    for i in range(K):
        w = np.sqrt(0.5 * (seg[i] + seg[i - 1]))
        design[i, 0] = w
        c1, s1 = np.cos(phi[i]), np.sin(phi[i])
        ck, sk = c1, s1
        for k in range(1, modes + 1):  # cos k phi, sin k phi by the angle-addition recurrence
            design[i, 2 * k - 1] = ck * w
            design[i, 2 * k] = sk * w
            ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
        rhs[i] = r[i] * w
    # normal equations where well conditioned (the design's columns are near-orthogonal on a cell's
    # outline), the SVD least squares where not
    gram = design.T @ design
    ev = np.linalg.eigvalsh(gram)
    if ev[0] > ev[-1] * 1e-8:
        coef = np.linalg.solve(gram, design.T @ rhs)
    else:
        coef = np.linalg.lstsq(design, rhs)[0]
    T = ct.shape[1]
    h = 2 * np.pi / T
    perim = 0.0
    area = 0.0
    for i in range(T):
        R = coef[0]
        dR = 0.0
        for k in range(1, modes + 1):
            A, B = coef[2 * k - 1], coef[2 * k]
            R += A * ct[k - 1, i] + B * st[k - 1, i]
            dR += k * (B * ct[k - 1, i] - A * st[k - 1, i])
        perim += np.sqrt(R * R + dR * dR)
        area += R * R
    return coef, perim * h, 0.5 * area * h, star


@numba.njit(cache=True, error_model="numpy")
def resample(line, step):
    """The closed ``line`` (K, 2) resampled at equal arc-length steps of at most ``step`` (at
    least 8 points, from its first point; linear interpolation as ``np.interp``): ``(p, h)``,
    h the step."""
    K = line.shape[0]
    s = np.empty(K + 1)
    s[0] = 0.0
    acc = 0.0
    for i in range(K):
        j = (i + 1) % K
        acc += np.hypot(line[j, 0] - line[i, 0], line[j, 1] - line[i, 1])
        s[i + 1] = acc
    total = s[K]
    n = max(int(np.ceil(total / step)), 8)
    h = total / n
    p = np.empty((n, 2))
    j = 0
    for i in range(n):
        t = i * h
        while j + 1 < K and s[j + 1] <= t:
            j += 1
        if s[j] == t:
            p[i, 0], p[i, 1] = line[j, 0], line[j, 1]
            continue
        k = (j + 1) % K
        for d in range(2):
            slope = (line[k, d] - line[j, d]) / (s[j + 1] - s[j])
            p[i, d] = slope * (t - s[j]) + line[j, d]
    return p, h


@numba.njit(cache=True, error_model="numpy")
def _blur_pass(src, dst, weights, axis):
    """One axis of a separable symmetric correlation, zero outside the array (the operation order
    of ``scipy.ndimage.correlate1d`` with a symmetric kernel)."""
    r = weights.size // 2
    H, W = src.shape
    L = H if axis == 0 else W
    M = W if axis == 0 else H
    for m in range(M):
        for i in range(L):
            v = (src[i, m] if axis == 0 else src[m, i]) * weights[r]
            for j in range(r, 0, -1):
                a = 0.0
                b = 0.0
                if i - j >= 0:
                    a = src[i - j, m] if axis == 0 else src[m, i - j]
                if i + j < L:
                    b = src[i + j, m] if axis == 0 else src[m, i + j]
                v += (a + b) * weights[r - j]
            if axis == 0:
                dst[i, m] = v
            else:
                dst[m, i] = v


@numba.njit(cache=True, error_model="numpy")
def blurred_mask(mask, pad, weights):
    """The mask padded by ``pad`` zeros on each side and blurred with the separable symmetric
    kernel ``weights`` along rows, then columns (zero outside): ``scipy.ndimage.gaussian_filter``
    of the padded mask, ``mode="constant"``, when ``weights`` is its kernel."""
    H, W = mask.shape
    z = np.zeros((H + 2 * pad, W + 2 * pad))
    for r in range(H):
        for c in range(W):
            if mask[r, c]:
                z[r + pad, c + pad] = 1.0
    tmp = np.empty_like(z)
    _blur_pass(z, tmp, weights, 0)
    _blur_pass(tmp, z, weights, 1)
    return z
