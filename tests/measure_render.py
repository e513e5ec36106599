"""Label stacks rendered from model cells, with the exact values on the same cells (not part of the package).

:func:`jittered_cells` places model cells (random admissible shapes, modes 2..6) on a jittered
triangular lattice, rejecting overlaps so that every cell's mask is its own contour;
:func:`render` rasterises their contours at ``res`` pixels per R0 by point-in-polygon at the
pixel centres (``(c + 1/2, r + 1/2)``), in a field of view that cuts the outer cells.
"""

import numpy as np
from matplotlib.path import Path as MplPath

from fcsweep.results.export import cell_contours
from fcsweep.analysis.shapes import shape_indices
from fcsweep.model.shape import bounding_radius, project_admissible


def jittered_cells(n_side, rng, *, spacing=2.6, step=0.3, sweeps=0, amp=0.08, modes=6):
    """Non-overlapping model cells (R0 = 1): pos (N, 2), theta (N,), a, b (N, M-1).

    A triangular lattice of ``spacing``, then ``sweeps`` Monte Carlo sweeps of moves of
    ``step`` times the spacing that keep the cells' bounding discs apart: a hard-disc crystal
    or fluid, depending on the spacing, with generic (non-degenerate) Voronoi vertices.
    """
    xs, ys = np.meshgrid(np.arange(n_side), np.arange(n_side))
    pos = np.stack([(xs + 0.5 * (ys % 2)).ravel() * spacing, ys.ravel() * spacing * np.sqrt(3) / 2], 1)
    N = pos.shape[0]
    a = rng.normal(0, amp, (N, modes - 1)) / np.arange(2, modes + 1) ** 0.5
    b = rng.normal(0, amp, (N, modes - 1)) / np.arange(2, modes + 1) ** 0.5
    a, b = project_admissible(a, b)[:2]
    rmax = bounding_radius(a, b)
    pos = pos + rng.uniform(-0.02, 0.02, pos.shape)
    for k in rng.integers(N, size=sweeps * N):
        trial = pos[k] + rng.uniform(-step, step, 2) * spacing
        d = np.hypot(*(pos - trial).T)
        d[k] = np.inf
        if np.all(d > rmax + rmax[k] + 0.05):
            pos[k] = trial
    return pos, rng.uniform(0, 2 * np.pi, N), a, b


def render(pos, theta, a, b, res, fov):
    """Label frame of the cells at ``res`` px per R0 in ``fov = (x0, x1, y0, y1)`` (R0 units)."""
    x0, x1, y0, y1 = fov
    nx, ny = int(round((x1 - x0) * res)), int(round((y1 - y0) * res))
    frame = np.zeros((ny, nx), dtype=np.int32)
    contours = cell_contours(pos, theta, a, b, points=400)
    for k, c in enumerate(contours):
        cx, cy = (c[:, 0] - x0) * res, (c[:, 1] - y0) * res
        c0, c1 = max(int(cx.min()) - 1, 0), min(int(cx.max()) + 2, nx)
        r0, r1 = max(int(cy.min()) - 1, 0), min(int(cy.max()) + 2, ny)
        if c0 >= c1 or r0 >= r1:
            continue
        gx, gy = np.meshgrid(np.arange(c0, c1) + 0.5, np.arange(r0, r1) + 0.5)
        inside = MplPath(np.stack([cx, cy], 1)).contains_points(np.stack([gx.ravel(), gy.ravel()], 1))
        block = frame[r0:r1, c0:c1]
        block[inside.reshape(block.shape)] = k + 1
    return frame


def exact_q(a, b):
    """The model's shape index of each cell."""
    return shape_indices(a, b)


def render_overlapping(pos, theta, a, b, box, res, fov):
    """Label frame of simulated cells in a periodic ``box``, which may overlap: a pixel inside
    several contours goes to the cell for which it is deepest (smallest ``|p - r_i| / R_i(phi)``).
    Periodic images of the cells are drawn, so ``fov`` may be anywhere inside the box."""
    from fcsweep.model.shape import radius

    x0, x1, y0, y1 = fov
    nx, ny = int(round((x1 - x0) * res)), int(round((y1 - y0) * res))
    frame = np.zeros((ny, nx), dtype=np.int32)
    best = np.full((ny, nx), np.inf)
    shifts = [np.array([i * box[0], j * box[1]]) for i in (-1, 0, 1) for j in (-1, 0, 1)]
    contours = cell_contours(pos, theta, a, b, points=400)
    for k, c0 in enumerate(contours):
        for sh in shifts:
            c = c0 + sh
            cx, cy = (c[:, 0] - x0) * res, (c[:, 1] - y0) * res
            col0, col1 = max(int(cx.min()) - 1, 0), min(int(cx.max()) + 2, nx)
            row0, row1 = max(int(cy.min()) - 1, 0), min(int(cy.max()) + 2, ny)
            if col0 >= col1 or row0 >= row1:
                continue
            gx, gy = np.meshgrid(np.arange(col0, col1) + 0.5, np.arange(row0, row1) + 0.5)
            pts = np.stack([gx.ravel(), gy.ravel()], 1)
            inside = MplPath(np.stack([cx, cy], 1)).contains_points(pts).reshape(gx.shape)
            dx = gx / res + x0 - (pos[k, 0] + sh[0])
            dy = gy / res + y0 - (pos[k, 1] + sh[1])
            phi = np.arctan2(dy, dx) - theta[k]
            R = radius(phi.ravel(), a[k], b[k])[0].reshape(gx.shape)
            depth = np.where(inside, np.hypot(dx, dy) / R, np.inf)
            blk = best[row0:row1, col0:col1]
            win = depth < blk
            blk[win] = depth[win]
            frame[row0:row1, col0:col1][win] = k + 1
    return frame


def voronoi_base(size, r0_px, seed=0, margin=0):
    """A confluent label image: the Voronoi cells of a jittered triangular lattice whose cells
    have the area of a disc of radius ``r0_px`` pixels, ``size + margin`` pixels square
    (uint32, labels 1..n).  A movie of rigidly drifting cells is a sequence of
    ``size`` x ``size`` windows of it (:func:`drifting_frames`)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    n = size + margin
    s = r0_px * np.sqrt(2 * np.pi / np.sqrt(3))  # lattice spacing of cells of area pi r0^2
    cols, rows = int(n / s) + 2, int(n / (s * np.sqrt(3) / 2)) + 2
    xs, ys = np.meshgrid(np.arange(cols), np.arange(rows))
    pts = np.stack([(xs + 0.5 * (ys % 2)).ravel() * s, ys.ravel() * s * np.sqrt(3) / 2], 1) - s / 2
    pts += rng.uniform(-0.15 * s, 0.15 * s, pts.shape)
    tree = cKDTree(pts)
    out = np.empty((n, n), dtype=np.uint32)
    centres = np.arange(n) + 0.5
    for r0 in range(0, n, 256):  # rows in blocks: bounded work memory
        yy, xx = np.meshgrid(centres[r0:r0 + 256], centres, indexing="ij")
        out[r0:r0 + 256] = tree.query(np.stack([xx.ravel(), yy.ravel()], 1))[1].reshape(yy.shape) + 1
    return out


def drifting_frames(base, size, frames, step=1):
    """``frames`` windows of ``size`` x ``size`` pixels of ``base``, each ``step`` pixels further
    along the diagonal and back at the end of the margin, as views: cells drift rigidly to and
    fro, and those near the edges leave and enter."""
    span = base.shape[0] - size
    for k in range(frames):
        d = span - abs((k * step) % (2 * span) - span) if span else 0
        yield base[d:d + size, d:d + size]


def shape_frame(inside, extent, rng):
    """A label frame holding one shape (label 1), Gauss-digitised: a pixel is in the cell when
    its centre is (``inside(x, y)`` on arrays of pixel centres, the shape centred at 0), placed at
    a random sub-pixel offset in a square of ``2 * extent + 8`` pixels."""
    n = int(2 * extent) + 8
    off = rng.uniform(0, 1, 2)
    gx, gy = np.meshgrid(np.arange(n) + 0.5 - n / 2 - off[0], np.arange(n) + 0.5 - n / 2 - off[1])
    return inside(gx, gy).astype(np.int32)


def ellipse_frame(a, b, theta, rng):
    """An ellipse of semi-axes ``a``, ``b`` (pixels) at angle ``theta``, and its exact q."""
    def inside(x, y):
        u, w = x * np.cos(theta) + y * np.sin(theta), -x * np.sin(theta) + y * np.cos(theta)
        return (u / a) ** 2 + (w / b) ** 2 < 1

    t = np.linspace(0, 2 * np.pi, 40001)[:-1]
    P = np.hypot(a * np.sin(t), b * np.cos(t)).mean() * 2 * np.pi
    return shape_frame(inside, max(a, b), rng), P / np.sqrt(np.pi * a * b)


def polygon_frame(verts, rng):
    """A polygon (vertices about 0, pixels), and its exact q."""
    verts = np.asarray(verts, dtype=float)
    path = MplPath(verts)

    def inside(x, y):
        return path.contains_points(np.stack([x.ravel(), y.ravel()], 1)).reshape(x.shape)

    d = np.diff(verts, axis=0, append=verts[:1])
    P = np.hypot(d[:, 0], d[:, 1]).sum()
    A = 0.5 * abs(np.sum(verts[:, 0] * np.roll(verts[:, 1], -1) - np.roll(verts[:, 0], -1) * verts[:, 1]))
    return shape_frame(inside, np.abs(verts).max(), rng), P / np.sqrt(A)


def regular_polygon(n, R, theta=0.0):
    """Vertices of a regular n-gon of circumradius R about 0."""
    t = theta + 2 * np.pi * np.arange(n) / n
    return np.stack([R * np.cos(t), R * np.sin(t)], 1)


def voronoi_monolayer(size, cell_px, rng, jitter=0.35):
    """A confluent monolayer of exact Voronoi polygons: seeds on a triangular lattice of spacing
    ``cell_px`` (cells about ``cell_px`` pixels across) jittered by ``jitter`` spacings, each
    pixel labelled with its nearest seed.  Returns the frame (size x size) and the exact q of each
    label's polygon (index = label; NaN for cells whose polygon reaches within 2 px of the edge)."""
    from scipy.spatial import Voronoi, cKDTree

    s = cell_px
    cols, rows = int(size / s) + 3, int(size / (s * np.sqrt(3) / 2)) + 3
    xs, ys = np.meshgrid(np.arange(cols), np.arange(rows))
    pts = np.stack([(xs + 0.5 * (ys % 2)).ravel() * s, ys.ravel() * s * np.sqrt(3) / 2], 1) - s
    pts += rng.uniform(-jitter * s, jitter * s, pts.shape)
    c = np.arange(size) + 0.5
    yy, xx = np.meshgrid(c, c, indexing="ij")
    frame = (cKDTree(pts).query(np.stack([xx.ravel(), yy.ravel()], 1))[1] + 1).reshape(size, size)
    vor = Voronoi(pts)
    q = np.full(len(pts) + 1, np.nan)
    for i, reg in enumerate(vor.point_region):
        r = vor.regions[reg]
        if not r or -1 in r:
            continue
        v = vor.vertices[r]
        if v.min() < 2 or v.max() > size - 2:
            continue
        v = v[np.argsort(np.arctan2(v[:, 1] - pts[i, 1], v[:, 0] - pts[i, 0]))]
        d = np.diff(v, axis=0, append=v[:1])
        A = 0.5 * abs(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
        q[i + 1] = np.hypot(d[:, 0], d[:, 1]).sum() / np.sqrt(A)
    return frame.astype(np.int32), q
