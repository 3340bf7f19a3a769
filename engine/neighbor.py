"""Cell-list neighbor lists with a skin, rebuilt when a particle has moved more than skin/2.

The list is a *half* list in CSR form: pair k = (i, nbr_j[k]) for nbr_start[i] <= k < nbr_start[i+1], always
with i < j, so each pair is visited once and Newton's third law gives j its force. A rebuild also
(1) wraps periodic coordinates, (2) removes particles that left a fixed box, (3) re-orders the particles by
cell so that neighbors are close in memory, and (4) carries every pair's contact history over to the new
list (history rows follow their pair through the re-ordering; a pair that swaps its i/j roles gets its
history negated, since every history vector we store is antisymmetric in i and j).
"""
from collections import namedtuple

import numpy as np
from numba import njit

from .state import reorder

#: the half list in CSR form and the contact history of each listed pair (width 0 without a history submodel)
NeighborList = namedtuple("NeighborList", ["start", "j", "hist"])
#: particles removed for leaving a fixed axis' range: ids, steps, and count[0] entries used
LostParticles = namedtuple("LostParticles", ["ids", "steps", "count"])


def empty_list(history: int = 0) -> NeighborList:
    return NeighborList(np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int32), np.zeros((0, history)))


def lost_record(capacity: int) -> LostParticles:
    return LostParticles(np.zeros(capacity, np.int64), np.zeros(capacity, np.int64), np.zeros(1, np.int64))

#: bins per particle above which the cell grid is coarsened, keeps memory linear in N
MAX_CELLS_PER_PARTICLE = 8


@njit(cache=True, error_model="numpy")
def max_displacement_check(x, x_build, half_skin_sq, n):
    """(rebuild needed, index of the first of the n particles with a non-finite position or -1)."""
    need = False
    for i in range(n):
        dx = x[i, 0] - x_build[i, 0]
        dy = x[i, 1] - x_build[i, 1]
        dz = x[i, 2] - x_build[i, 2]
        d2 = dx * dx + dy * dy + dz * dz
        if d2 > half_skin_sq:
            need = True
        elif not d2 <= half_skin_sq:  # NaN fails every comparison
            return need, i
    return need, -1


@njit(cache=True, error_model="numpy")
def _axis_neighbor_cells(c, nc, periodic, out):
    """Distinct neighbor cell indices of cell c along one axis; returns how many were written to out."""
    m = 0
    if periodic:
        if nc >= 3:
            out[0] = (c - 1) % nc
            out[1] = c
            out[2] = (c + 1) % nc
            m = 3
        else:
            for q in range(nc):
                out[q] = q
            m = nc
    else:
        for q in range(c - 1, c + 2):
            if q >= 0 and q < nc:
                out[m] = q
                m += 1
    return m


@njit(cache=True, error_model="numpy")
def rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost):
    """Rebuild the neighbor list of the first n particles of state s; see the module docstring.

    The particle rows of s are re-ordered in place (lost particles dropped: the survivors fill the first rows).
    lost: a LostParticles record, its count incremented per lost particle. Returns (particles kept, new list).
    """
    x = s.x
    radius = s.radius
    pid = s.pid
    nbr_start = nbr.start
    nbr_j = nbr.j
    pair_hist = nbr.hist
    box = hi - lo
    keep = np.ones(n, dtype=np.bool_)
    for i in range(n):
        for a in range(3):
            if periodic[a]:
                if x[i, a] < lo[a] or x[i, a] >= hi[a]:
                    x[i, a] -= box[a] * np.floor((x[i, a] - lo[a]) / box[a])
            elif x[i, a] < lo[a] or x[i, a] > hi[a]:
                keep[i] = False
        if not keep[i]:
            lost.ids[lost.count[0]] = pid[i]
            lost.steps[lost.count[0]] = step
            lost.count[0] += 1
    kept = np.nonzero(keep)[0]
    nk = kept.shape[0]

    # cell grid: periodic axes span the box, fixed axes only the particles' bounding box (memory ~ N)
    rmax = 0.0
    for q in range(nk):
        rmax = max(rmax, radius[kept[q]])
    cutoff = 2.0 * rmax + skin
    origin = np.empty(3)
    extent = np.empty(3)
    for a in range(3):
        if periodic[a]:
            origin[a] = lo[a]
            extent[a] = box[a]
        else:
            xmin = np.inf
            xmax = -np.inf
            for q in range(nk):
                xmin = min(xmin, x[kept[q], a])
                xmax = max(xmax, x[kept[q], a])
            if nk == 0:
                xmin = 0.0
                xmax = 0.0
            origin[a] = xmin
            extent[a] = xmax - xmin
    cell = cutoff
    nc = np.ones(3, dtype=np.int64)
    while True:
        for a in range(3):
            nc[a] = max(1, int(extent[a] / cell)) if periodic[a] else int(extent[a] / cell) + 1
        if nc[0] * nc[1] * nc[2] <= MAX_CELLS_PER_PARTICLE * nk + 64:
            break
        cell *= 1.25
    cell_size = np.empty(3)
    for a in range(3):
        cell_size[a] = extent[a] / nc[a] if periodic[a] else cell
    ncells = nc[0] * nc[1] * nc[2]
    cell_of = np.empty(nk, dtype=np.int64)
    for q in range(nk):
        i = kept[q]
        c = 0
        for a in range(3):
            ca = int((x[i, a] - origin[a]) / cell_size[a])
            ca = min(max(ca, 0), nc[a] - 1)
            c = c * nc[a] + ca
        cell_of[q] = c
    # counting sort by cell: the new particle order (stable, so deterministic)
    cell_start = np.zeros(ncells + 1, dtype=np.int64)
    for q in range(nk):
        cell_start[cell_of[q] + 1] += 1
    for c in range(ncells):
        cell_start[c + 1] += cell_start[c]
    fill = cell_start[:-1].copy()
    order = np.empty(nk, dtype=np.int64)
    new_cell = np.empty(nk, dtype=np.int64)
    for q in range(nk):
        c = cell_of[q]
        order[fill[c]] = kept[q]
        new_cell[fill[c]] = c
        fill[c] += 1
    new_index = -np.ones(n, dtype=np.int64)
    for q in range(nk):
        new_index[order[q]] = q

    reorder(s, order)

    # pairs within cutoff_ij = r_i + r_j + skin, half list with i < j
    capacity = max(nbr_j.shape[0] + nbr_j.shape[0] // 4, 8 * nk + 16)
    new_j = np.empty(capacity, dtype=np.int32)
    new_start = np.zeros(nk + 1, dtype=np.int64)
    ox = np.empty(3, dtype=np.int64)
    oy = np.empty(3, dtype=np.int64)
    oz = np.empty(3, dtype=np.int64)
    m = 0
    for i in range(nk):
        c = new_cell[i]
        cz = c % nc[2]
        cy = (c // nc[2]) % nc[1]
        cx = c // (nc[1] * nc[2])
        mx = _axis_neighbor_cells(cx, nc[0], periodic[0], ox)
        my = _axis_neighbor_cells(cy, nc[1], periodic[1], oy)
        mz = _axis_neighbor_cells(cz, nc[2], periodic[2], oz)
        ri = radius[i]
        for qa in range(mx):
            for qb in range(my):
                for qc in range(mz):
                    cc = (ox[qa] * nc[1] + oy[qb]) * nc[2] + oz[qc]
                    for j in range(max(cell_start[cc], i + 1), cell_start[cc + 1]):
                        d0 = x[i, 0] - x[j, 0]
                        d1 = x[i, 1] - x[j, 1]
                        d2 = x[i, 2] - x[j, 2]
                        if periodic[0]:
                            d0 -= box[0] * np.rint(d0 / box[0])
                        if periodic[1]:
                            d1 -= box[1] * np.rint(d1 / box[1])
                        if periodic[2]:
                            d2 -= box[2] * np.rint(d2 / box[2])
                        cut = ri + radius[j] + skin
                        if d0 * d0 + d1 * d1 + d2 * d2 < cut * cut:
                            if m == capacity:
                                capacity *= 2
                                grown = np.empty(capacity, dtype=np.int32)
                                grown[:m] = new_j[:m]
                                new_j = grown
                            new_j[m] = j
                            m += 1
        new_start[i + 1] = m
    new_j = new_j[:m].copy()
    # neighbors of i in increasing j: the force sums do not depend on cell traversal details
    for i in range(nk):
        new_j[new_start[i]:new_start[i + 1]] = np.sort(new_j[new_start[i]:new_start[i + 1]])

    width = pair_hist.shape[1]
    new_hist = np.zeros((m if width > 0 else 0, width))
    if width > 0:
        # bucket the old pairs that carry history by their new smaller index
        bucket_count = np.zeros(nk + 1, dtype=np.int64)
        n_old = nbr_start.shape[0] - 1
        for io in range(n_old):
            for k in range(nbr_start[io], nbr_start[io + 1]):
                a = new_index[io]
                b = new_index[nbr_j[k]]
                if a < 0 or b < 0:
                    continue
                nonzero = False
                for h in range(width):
                    if pair_hist[k, h] != 0.0:
                        nonzero = True
                if nonzero:
                    bucket_count[min(a, b) + 1] += 1
        for q in range(nk):
            bucket_count[q + 1] += bucket_count[q]
        bfill = bucket_count[:-1].copy()
        total = bucket_count[nk]
        b_other = np.empty(total, dtype=np.int64)
        b_hist = np.empty((total, width))
        for io in range(n_old):
            for k in range(nbr_start[io], nbr_start[io + 1]):
                a = new_index[io]
                b = new_index[nbr_j[k]]
                if a < 0 or b < 0:
                    continue
                nonzero = False
                for h in range(width):
                    if pair_hist[k, h] != 0.0:
                        nonzero = True
                if not nonzero:
                    continue
                sign = 1.0
                if a > b:
                    a, b = b, a
                    sign = -1.0
                p = bfill[a]
                b_other[p] = b
                for h in range(width):
                    b_hist[p, h] = sign * pair_hist[k, h]
                bfill[a] += 1
        for i in range(nk):
            for p in range(bucket_count[i], bucket_count[i + 1]):
                for k in range(new_start[i], new_start[i + 1]):
                    if new_j[k] == b_other[p]:
                        for h in range(width):
                            new_hist[k, h] = b_hist[p, h]
                        break
    for i in range(nk):
        for a in range(3):
            s.x_build[i, a] = x[i, a]
    return nk, NeighborList(new_start, new_j, new_hist)


@njit(cache=True, error_model="numpy")
def overlap_statistics(x, radius, nbr_start, nbr_j, lo, hi, periodic, ratio_limit):
    """(number of contacts, contacts with overlap > ratio_limit * smaller radius, max overlap / smaller radius)."""
    box = hi - lo
    n_contacts = 0
    n_large = 0
    worst = 0.0
    for i in range(nbr_start.shape[0] - 1):
        for k in range(nbr_start[i], nbr_start[i + 1]):
            j = nbr_j[k]
            d = np.empty(3)
            for a in range(3):
                d[a] = x[i, a] - x[j, a]
                if periodic[a]:
                    d[a] -= box[a] * np.rint(d[a] / box[a])
            r = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            overlap = radius[i] + radius[j] - r
            if overlap > 0.0:
                n_contacts += 1
                ratio = overlap / min(radius[i], radius[j])
                worst = max(worst, ratio)
                if ratio > ratio_limit:
                    n_large += 1
    return n_contacts, n_large, worst
