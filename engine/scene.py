"""Scene set-up helpers: particle insertion (lattice, seeded random packing)."""
from __future__ import annotations

import math

import numpy as np
from .jit import njit

from . import memory



def region_contains(region: dict, points: np.ndarray, margin: np.ndarray) -> np.ndarray:
    """Which points (n, 3) lie in the region with a clearance of margin (n,) m to its boundary."""
    if region["shape"] == "box":
        lo = np.asarray(region["lo"])
        hi = np.asarray(region["hi"])
        m = margin[:, None]
        return np.all((points >= lo + m) & (points <= hi - m), axis=1)
    cx, cy = region["center"]
    rho = np.hypot(points[:, 0] - cx, points[:, 1] - cy)
    zlo, zhi = region["z"]
    return (rho <= region["radius"] - margin) & (points[:, 2] >= zlo + margin) & (points[:, 2] <= zhi - margin)


def region_bounds(region: dict):
    """Axis-aligned bounding box (lo, hi) of a region, m."""
    if region["shape"] == "box":
        return np.asarray(region["lo"], float), np.asarray(region["hi"], float)
    cx, cy = region["center"]
    r = region["radius"]
    return (np.array([cx - r, cy - r, region["z"][0]]), np.array([cx + r, cy + r, region["z"][1]]))


def lattice_points(region: dict, spacing: float, radius: float) -> np.ndarray:
    """Simple cubic lattice of sphere centres (spacing m) that fit entirely inside the region."""
    lo, hi = region_bounds(region)
    axes = [lo[a] + 0.5 * spacing + spacing * np.arange(max(0, int(math.floor((hi[a] - lo[a]) / spacing))))
            for a in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return grid[region_contains(region, grid, np.full(len(grid), radius))]


@njit(cache=True, error_model="numpy")
def _grid_insert(px, pr, head, nxt, count, point, r, grid_lo, cell, ncell):
    """Put a sphere (centre point, radius r) into the cell lists; returns the new count."""
    key = 0
    for a in range(3):
        c = min(max(int(math.floor((point[a] - grid_lo[a]) / cell)), 0), ncell[a] - 1)
        key = key * ncell[a] + c
    px[count] = point
    pr[count] = r
    nxt[count] = head[key]
    head[key] = count
    return count + 1


@njit(cache=True, error_model="numpy")
def _grid_start(existing_x, existing_r, total, grid_lo, cell, ncell):
    """Cell lists (px, pr, head, nxt, count) holding the existing particles inside the grid."""
    px = np.empty((total, 3))
    pr = np.empty(total)
    head = -np.ones(ncell[0] * ncell[1] * ncell[2], dtype=np.int64)
    nxt = -np.ones(total, dtype=np.int64)
    count = 0
    for e in range(existing_x.shape[0]):
        inside = True
        for a in range(3):
            c = int(math.floor((existing_x[e, a] - grid_lo[a]) / cell))
            if c < 0 or c >= ncell[a]:
                inside = False
        if inside:
            count = _grid_insert(px, pr, head, nxt, count, existing_x[e], existing_r[e], grid_lo, cell, ncell)
    return px, pr, head, nxt, count


@njit(cache=True, error_model="numpy")
def _place_spheres(radii, candidates, shape, lo, hi, center, cyl_radius, grid_lo, cell, ncell, px, pr, head,
                   nxt, count, out, placed):
    """Random sequential addition: candidates (uniform in the region's bounding box) are tried in order.

    A candidate is taken for the next sphere (radius radii[placed]) if the whole sphere lies in the region
    (shape 0 = box lo..hi, 1 = z-cylinder with centre, radius and z range lo[2]..hi[2]) and it overlaps
    neither an existing particle nor an already placed one (cell lists px, pr, head, nxt). Placed centres go
    to out. Returns (count, placed) after this batch of candidates.
    """
    n_new = radii.shape[0]
    c = np.empty(3, dtype=np.int64)
    for k in range(candidates.shape[0]):
        if placed == n_new:
            break
        cand = candidates[k]
        r = radii[placed]
        if shape == 0:
            ok = True
            for a in range(3):
                if cand[a] < lo[a] + r or cand[a] > hi[a] - r:
                    ok = False
        else:
            rho = math.sqrt((cand[0] - center[0]) ** 2 + (cand[1] - center[1]) ** 2)
            ok = rho <= cyl_radius - r and cand[2] >= lo[2] + r and cand[2] <= hi[2] - r
        if not ok:
            continue
        for a in range(3):
            c[a] = min(max(int(math.floor((cand[a] - grid_lo[a]) / cell)), 0), ncell[a] - 1)
        for qx in range(max(c[0] - 1, 0), min(c[0] + 2, ncell[0])):
            for qy in range(max(c[1] - 1, 0), min(c[1] + 2, ncell[1])):
                for qz in range(max(c[2] - 1, 0), min(c[2] + 2, ncell[2])):
                    p = head[(qx * ncell[1] + qy) * ncell[2] + qz]
                    while p >= 0 and ok:
                        d0 = cand[0] - px[p, 0]
                        d1 = cand[1] - px[p, 1]
                        d2 = cand[2] - px[p, 2]
                        if d0 * d0 + d1 * d1 + d2 * d2 < (r + pr[p]) ** 2:
                            ok = False
                        p = nxt[p]
        if not ok:
            continue
        count = _grid_insert(px, pr, head, nxt, count, cand, r, grid_lo, cell, ncell)
        out[placed] = cand
        placed += 1
    return count, placed


#: candidates drawn at a time: the table of all max_attempts x count candidates (24 B each: 5 GB for 1e6
#: spheres at 200 attempts) is never held; drawing in batches gives the same numbers (one stream)
CANDIDATE_BATCH = memory.PACKING_BATCH


def random_packing(region: dict, radii: np.ndarray, seed: int, existing_x: np.ndarray, existing_r: np.ndarray,
                   max_attempts: int) -> np.ndarray:
    """Seeded random sequential packing of spheres with the given radii (m) into a region, no overlaps.

    The same seed gives the same positions (numpy PCG64 stream, candidates tried in a fixed order). At most
    max_attempts candidates per sphere are drawn; returns the centres placed (fewer when they ran out).
    """
    rng = np.random.Generator(np.random.PCG64(seed))
    lo, hi = region_bounds(region)
    # the grid must see the largest sphere anywhere near the region: existing ones may be bigger
    rmax = float(max(radii.max(), existing_r.max() if len(existing_r) else 0.0))
    cell = 2.0 * rmax
    n_total = len(radii) + len(existing_r)
    while True:
        grid_lo = lo - cell
        ncell = np.maximum(1, np.ceil((hi - lo + 2 * cell) / cell).astype(np.int64))
        if ncell.prod() <= 8 * n_total + 1000:
            break
        cell *= 1.25
    shape = 0 if region["shape"] == "box" else 1
    center = np.asarray(region.get("center", [0.0, 0.0]), dtype=np.float64)
    px, pr, head, nxt, count = _grid_start(np.ascontiguousarray(existing_x, dtype=np.float64).reshape(-1, 3),
                                           np.ascontiguousarray(existing_r, dtype=np.float64), n_total, grid_lo,
                                           cell, ncell)
    out = np.empty((len(radii), 3))
    placed = 0
    left = max_attempts * len(radii)
    while left > 0 and placed < len(radii):
        batch = min(left, CANDIDATE_BATCH)
        candidates = lo + rng.random((batch, 3)) * (hi - lo)
        count, placed = _place_spheres(radii, candidates, shape, lo, hi, center, float(region.get("radius", 0.0)),
                                       grid_lo, cell, ncell, px, pr, head, nxt, count, out, placed)
        left -= batch
    return out[:placed]
