"""Cell-list neighbor lists with a skin, rebuilt when a particle has moved more than skin/2.

The list is a *half* list in CSR form: pair k = (i, j[k]) for start[i] <= k < start[i+1], always with i < j and
j increasing, so each pair is evaluated once (by i), which adds the reaction to j's force. On several threads
each thread takes one share of the particles (`share_start`); a particle j listed by a particle of an earlier
share (the boundary band, `boundary_band`) would get sums from two threads, so for it alone i leaves the
reaction in the pair's row of `reaction`, and j collects the rows of the pairs it belongs to, in the order a
serial loop would have added them. The rows are ordered by partner (rows rstart[j]..rstart[j+1] are the pairs
(i, j), i increasing; pair k writes row rslot[k]), so j reads its rows in one sweep. Forces are therefore
bitwise the same on any number of threads, and the same as a serial half-list loop (engine/kernels.py).

A rebuild (1) wraps periodic coordinates, (2) removes particles that left a fixed box, (3) re-orders the
particles by cell so that neighbors are close in memory, (4) builds the list and its reverse index, and (5)
carries every pair's contact history over to the new list (history rows follow their pair through the
re-ordering; a pair that swaps its i/j roles gets each history column multiplied by its law's transfer factor,
engine.models.Law.transfer: -1 for the vectors antisymmetric in i and j). The loops over particles run on all threads; what they write depends only on
the particle, never on the thread count.
"""
from collections import namedtuple

import numpy as np
from llvmlite import ir
from numba import prange, types
from numba.core import cgutils
from numba.extending import intrinsic

from .jit import njit

from .state import reorder

#: prange loops only: Numba must not turn numpy calls into parallel reductions of its own (their summation
#: order would depend on the thread count)
PARALLEL = dict(prange=True, numpy=False, reduction=False, setitem=False, stencil=False, comprehension=False,
                fusion=False)

#: start (n+1), j (int32): the half list; hist (pairs, width): contact history; reaction (pairs, width): what j
#: takes from each pair this step (force, and torques), in partner order: rows rstart[p]..rstart[p+1] (rstart:
#: n+1) belong to the pairs (i, p), i increasing; rslot[k] is the row of pair k; touch (pairs, uint8, in the
#: rows' order): 1 when the row's pair is in contact at this step (its reaction row holds its share), 0 when not
#: (its row is not written: it holds what an earlier step left); own (n, uint8): 1 when particle i had a contact
#: as the first of a pair at this step, 0 when not (not used by the kernels);
#: live, per listed pair in the list's order: 0 when the pair's history is +0.0 in every column (it was apart at
#: the last force evaluation, or new), so that a pair found apart again need not read it; 1 when it may be nonzero
#: (the pair touched, or the list came from elsewhere: restart, insertion). The pair pass sets it for each contact
#: and clears it where it resets a history (engine/kernels.py FAR); the rebuild derives it from the carried rows.
#: band (n, uint8): 1 for the particles of the boundary band (`boundary_band`), members (n, int64): their indices
#: in increasing order, the first shares[1] entries; shares (2, int64): the share count the band was computed
#: for (0: not yet, after a rebuild or a change of the particles) and the band's size
NeighborList = namedtuple("NeighborList", ["start", "j", "hist", "rstart", "rslot", "reaction", "touch", "own",
                                           "live", "band", "members", "shares"])
#: particles removed for leaving a fixed axis' range: ids, steps, and count[0] entries used
LostParticles = namedtuple("LostParticles", ["ids", "steps", "count"])

#: bins per particle above which the cell grid is coarsened, keeps memory linear in N
MAX_CELLS_PER_PARTICLE = 8


def stale_band(n: int) -> dict:
    """The band fields of a list of n particles, to be computed before the next force evaluation."""
    return dict(band=np.zeros(n, np.uint8), members=np.zeros(n, np.int64), shares=np.zeros(2, np.int64))


def empty_list(history: int = 0, reaction: int = 3) -> NeighborList:
    return NeighborList(np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int32), np.zeros((0, history)),
                        np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, reaction)),
                        np.zeros(0, dtype=np.uint8), np.zeros(0, dtype=np.uint8), np.zeros(0, dtype=np.uint8),
                        **stale_band(0))


def from_half_list(start, j, hist, n: int, reaction: int) -> NeighborList:
    """The full record of a half list (as restart files store it) for n particles; every pair's history is
    tested at its first evaluation (live 1)."""
    rstart, rslot = reverse_index(start, j, n)
    return NeighborList(start, j, hist, rstart, rslot, np.zeros((len(j), reaction)), np.zeros(len(j), np.uint8),
                        np.zeros(n, np.uint8), np.ones(len(j), np.uint8), **stale_band(n))


def lost_record(capacity: int) -> LostParticles:
    return LostParticles(np.zeros(capacity, np.int64), np.zeros(capacity, np.int64), np.zeros(1, np.int64))


@intrinsic
def _threads(typingctx):
    """The threads of the next parallel loop (numba.set_num_threads): the threading layer's get_num_threads
    called by name, as Numba's parallel loops call it. numba.get_num_threads() in compiled code goes through a
    ctypes pointer, which keeps the function out of the disk cache."""
    def codegen(context, builder, signature, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(cgutils.intp_t, []), "get_num_threads")
        return builder.call(fn, [])
    return types.intp(), codegen


@njit(cache=True, error_model="numpy")
def block_count(n, size):
    """How many blocks of at most `size` particles a parallel loop over n particles takes: a multiple of the
    thread count, block k being particles k n // blocks ... (k + 1) n // blocks. OpenMP hands each thread one
    contiguous share of the blocks (a static schedule), so every thread gets the same number of particles (with
    blocks of exactly `size` the last is short and one thread had up to a block more than the other)."""
    if n == 0:
        return 0
    threads = _threads()
    blocks = (n + size - 1) // size
    return (blocks + threads - 1) // threads * threads


@njit(cache=True, error_model="numpy")
def share_start(t, shares, n, blocks):
    """First particle of thread t's share of a pair pass over n particles in `blocks` blocks (block_count, a
    multiple of shares): the shares are equal runs of whole blocks, block k being particles k n // blocks ..."""
    return (t * (blocks // shares)) * n // blocks


@njit(cache=True, error_model="numpy")
def boundary_band(start, j, n, shares, blocks, band, members):
    """Mark the band: the particles p listed by a pair (q, p) whose first particle q lies in an earlier share
    than p's (share_start), into band (1, else 0) and members (their indices, increasing). Returns their
    number. Only these particles take their partners' shares through reaction rows on several threads
    (engine/kernels.py PAIR_FORCES); every other particle's pairs are all in its own thread's share. A row's
    partners increase, so only its tail is read: the entries at or past the end of the share."""
    for p in range(n):
        band[p] = 0
    for t in range(shares):
        end = share_start(t + 1, shares, n, blocks)
        for q in range(share_start(t, shares, n, blocks), end):
            k = start[q + 1] - 1
            while k >= start[q] and j[k] >= end:
                band[j[k]] = 1
                k -= 1
    count = 0
    for p in range(n):
        if band[p]:
            members[count] = p
            count += 1
    return count


@njit(cache=True, error_model="numpy")
def start_band(nbr, n, size, f, torque):
    """Before a pair pass over n particles in blocks of `size` (engine/kernels.py PAIR_FORCES) on the current
    threads: the band (computed again after a rebuild or a change of the thread count), and the forces and
    torques of its particles set to +0.0 - there the pair pass stores only the particle's own sum (added to
    +0.0: the same bytes), the particle pass adds gravity and the reaction rows in the serial order."""
    shares = _threads()
    blocks = block_count(n, size)
    if nbr.shares[0] != shares:
        nbr.shares[1] = boundary_band(nbr.start, nbr.j, n, shares, blocks, nbr.band, nbr.members)
        nbr.shares[0] = shares
    for m in range(nbr.shares[1]):
        p = nbr.members[m]
        for a in range(3):
            f[p, a] = 0.0
            torque[p, a] = 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _bucket_starts(key, nbuckets):
    """First slot of each bucket when the entries are ordered by key (counting sort): start[b]..start[b + 1]
    hold the entries with key b; start[nbuckets] is the number of entries."""
    start = np.zeros(nbuckets + 1, dtype=np.int64)
    for k in range(key.shape[0]):
        start[key[k] + 1] += 1
    for b in range(nbuckets):
        start[b + 1] += start[b]
    return start


@njit(cache=True, error_model="numpy")
def reverse_index(start, j, n):
    """(rstart, rslot): rows rstart[p]..rstart[p+1] for the pairs k with j[k] == p in increasing k (so
    increasing i); rslot[k] the row of pair k."""
    m = j.shape[0]
    rstart = _bucket_starts(j, n)
    fill = rstart[:-1].copy()
    rslot = np.empty(m, dtype=np.int64)
    for k in range(m):
        p = j[k]
        rslot[k] = fill[p]
        fill[p] += 1
    return rstart, rslot


@njit(cache=True, error_model="numpy", inline="always")
def _axis_cells(c, nc, periodic):
    """Distinct neighbor cells of cell c along one axis: (how many, first, second, third)."""
    if periodic:
        if nc >= 3:
            return 3, (c - 1) % nc, c, (c + 1) % nc
        return nc, 0, 1, 0
    first = max(c - 1, 0)
    return min(c + 1, nc - 1) - first + 1, first, first + 1, first + 2


@njit(cache=True, error_model="numpy")
def _neighbor_cells(c, nc, periodic):
    """The neighbor cells of cell c (flat index over nc): per axis how many, then per axis their indices."""
    mx, x0, x1, x2 = _axis_cells(c // (nc[1] * nc[2]), nc[0], periodic[0])
    my, y0, y1, y2 = _axis_cells((c // nc[2]) % nc[1], nc[1], periodic[1])
    mz, z0, z1, z2 = _axis_cells(c % nc[2], nc[2], periodic[2])
    return mx, my, mz, (x0, x1, x2), (y0, y1, y2), (z0, z1, z2)


@njit(cache=True, error_model="numpy", inline="always")
def _z_runs(cz, nc, periodic):
    """The neighbor cells of cell row cz along the last axis as runs of consecutive cells, in increasing order:
    (how many runs, first cell and end of run 1, of run 2). Cells that follow each other along the last axis
    follow each other in the sorted particles, so a run of cells is one run of particles: a single loop instead
    of one per cell (each loop's end is a branch hard to predict)."""
    if periodic and nc >= 3 and (cz == 0 or cz == nc - 1):  # split by the wrap: 0, 1 | nc - 1 or 0 | nc - 2, nc - 1
        if cz == 0:
            return 2, 0, 2, nc - 1, nc
        return 2, 0, 1, nc - 2, nc
    if periodic:
        if nc >= 3:
            return 1, cz - 1, cz + 2, 0, 0
        return 1, 0, nc, 0, 0
    return 1, max(cz - 1, 0), min(cz + 1, nc - 1) + 1, 0, 0


@njit(cache=True, error_model="numpy")
def _find(row, value):
    """Index of value in the sorted array row, or -1."""
    lo = 0
    hi = row.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if row[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo if lo < row.shape[0] and row[lo] == value else -1


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _wrap(x, n, lo, hi, periodic, keep):
    """Periodic coordinates back into the box; keep[i] = False for particles outside a fixed axis' range."""
    box = hi - lo
    for i in prange(n):
        inside = True
        for a in range(3):
            if periodic[a]:
                if x[i, a] < lo[a] or x[i, a] >= hi[a]:
                    x[i, a] -= box[a] * np.floor((x[i, a] - lo[a]) / box[a])
            elif x[i, a] < lo[a] or x[i, a] > hi[a]:
                inside = False
        keep[i] = inside


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _cells(x, order, origin, cell_size, nc, cell_of):
    """Cell of each kept particle (order[q] is its index)."""
    for q in prange(order.shape[0]):
        i = order[q]
        c = 0
        for a in range(3):
            ca = int((x[i, a] - origin[a]) / cell_size[a])
            ca = min(max(ca, 0), nc[a] - 1)
            c = c * nc[a] + ca
        cell_of[q] = c


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _candidates(cell, cell_start, nc, periodic, count):
    """Upper bound of each particle's neighbors j > i: the particles of its neighbor cells after it."""
    for i in prange(cell.shape[0]):
        c = cell[i]
        mx, my, _, ox, oy, _ = _neighbor_cells(c, nc, periodic)
        runs, za0, za1, zb0, zb1 = _z_runs(c % nc[2], nc[2], periodic[2])
        total = 0
        for qa in range(mx):
            for qb in range(my):
                row = (ox[qa] * nc[1] + oy[qb]) * nc[2]
                total += max(0, cell_start[row + za1] - max(cell_start[row + za0], i + 1))
                if runs == 2:
                    total += max(0, cell_start[row + zb1] - max(cell_start[row + zb0], i + 1))
        count[i] = total


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _search(x, radius, cell, cell_start, nc, periodic, box, skin, slot, found, count):
    """Neighbors j > i within r_i + r_j + skin into found[slot[i]:], their number into count[i]."""
    p0 = periodic[0]
    p1 = periodic[1]
    p2 = periodic[2]
    b0 = box[0]
    b1 = box[1]
    b2 = box[2]
    for i in prange(cell.shape[0]):
        c = cell[i]
        mx, my, _, ox, oy, _ = _neighbor_cells(c, nc, periodic)
        ri = radius[i]
        # i's position in locals: the stores into found might alias x for all the compiler knows
        xi0 = x[i, 0]
        xi1 = x[i, 1]
        xi2 = x[i, 2]
        runs, za0, za1, zb0, zb1 = _z_runs(c % nc[2], nc[2], p2)
        m = slot[i]
        for qa in range(mx):
            for qb in range(my):
                row = (ox[qa] * nc[1] + oy[qb]) * nc[2]
                for run in range(runs):
                    first = row + (za0 if run == 0 else zb0)
                    end = row + (za1 if run == 0 else zb1)
                    for j in range(max(cell_start[first], i + 1), cell_start[end]):
                        d0 = xi0 - x[j, 0]
                        d1 = xi1 - x[j, 1]
                        d2 = xi2 - x[j, 2]
                        if p0:
                            d0 -= b0 * np.rint(d0 / b0)
                        if p1:
                            d1 -= b1 * np.rint(d1 / b1)
                        if p2:
                            d2 -= b2 * np.rint(d2 / b2)
                        cut = ri + radius[j] + skin
                        # every candidate written at the next slot, which only a neighbor keeps: no branch to
                        # mispredict (about 1 candidate in 6 is a neighbor; the row's slots hold all candidates)
                        found[m] = j
                        m += d0 * d0 + d1 * d1 + d2 * d2 < cut * cut
        count[i] = m - slot[i]


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _compact(found, slot, start, new_j):
    """Each row from the candidate slots into the list, j increasing (the order of the force sums)."""
    for i in prange(start.shape[0] - 1):
        # insertion sort while copying: a row is short and, but across a periodic boundary, already in order (the
        # search visits the neighbor cells in increasing index); np.sort would allocate a new array per row
        s0 = start[i]
        for m in range(start[i + 1] - s0):
            value = found[slot[i] + m]
            p = s0 + m
            while p > s0 and new_j[p - 1] > value:
                new_j[p] = new_j[p - 1]
                p -= 1
            new_j[p] = value


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _carry_history(order, old, new_start, new_j, new_hist, new_live, transfer):
    """Each new pair takes the history of the same pair in the old list (times transfer, per column, when i and
    j swapped roles), a new pair zeros. new_live[k] (NeighborList.live) is 0 for a new pair and for an old pair
    whose byte was 0 (its row +0.0, not read) unless its carried row is -0.0 (+0.0 times a negative transfer,
    which the pair pass must still reset); 1 for the others, whose rows may be nonzero.

    New pair (p, b) is old pair (order[p], order[b]): it is found in the old row of the smaller old index (a
    binary search in a row of a few entries); with order[b] the owner there, i and j swapped roles. Every new
    row is written by its owner only (all of it: new_hist comes uninitialised, no serial clearing pass).
    """
    n_old = old.start.shape[0] - 1
    width = new_hist.shape[1]
    for p in prange(new_start.shape[0] - 1):
        op = order[p]
        for k in range(new_start[p], new_start[p + 1]):
            ob = order[new_j[k]]
            pos = -1
            swapped = False
            if op < n_old and ob < n_old:
                if op < ob:
                    pos = _find(old.j[old.start[op]:old.start[op + 1]], ob)
                    if pos >= 0:
                        pos += old.start[op]
                else:
                    swapped = True
                    pos = _find(old.j[old.start[ob]:old.start[ob + 1]], op)
                    if pos >= 0:
                        pos += old.start[ob]
            if pos < 0:
                for h in range(width):
                    new_hist[k, h] = 0.0
                new_live[k] = 0
            elif old.live[pos] == 0:  # the old row is +0.0: not read, the same values written
                live = False
                for h in range(width):
                    value = transfer[h] * 0.0 if swapped else 0.0
                    new_hist[k, h] = value
                    live |= np.signbit(value)
                new_live[k] = live
            elif swapped:
                for h in range(width):
                    new_hist[k, h] = transfer[h] * old.hist[pos, h]
                new_live[k] = 1
            else:
                for h in range(width):
                    new_hist[k, h] = old.hist[pos, h]
                new_live[k] = 1


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def _copy_positions(x, x_build, n):
    for i in prange(n):
        for a in range(3):
            x_build[i, a] = x[i, a]


@njit(cache=True, error_model="numpy")
def _drop_lost(x, n, lo, hi, periodic, pid, step, lost):
    """Wrap periodic coordinates; the indices of the particles inside the fixed axes' range (the others are
    recorded in lost)."""
    keep = np.empty(n, dtype=np.bool_)
    _wrap(x, n, lo, hi, periodic, keep)
    nk = 0
    for i in range(n):
        if keep[i]:
            nk += 1
        else:
            lost.ids[lost.count[0]] = pid[i]
            lost.steps[lost.count[0]] = step
            lost.count[0] += 1
    kept = np.empty(nk, dtype=np.int64)
    q = 0
    for i in range(n):
        if keep[i]:
            kept[q] = i
            q += 1
    return kept


@njit(cache=True, error_model="numpy")
def _grid(x, radius, kept, lo, box, periodic, skin):
    """(origin, cell size, cells per axis) of the cell grid: periodic axes span the box, fixed axes only the
    particles' bounding box (memory ~ N); cells at least the cutoff 2 r_max + skin."""
    nk = kept.shape[0]
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
    return origin, cell_size, nc


@njit(cache=True, error_model="numpy")
def _sort_by_cell(cell_of, kept, ncells):
    """Counting sort of the kept particles by cell (stable, so deterministic): (new order as old indices, cell
    of each new index, first new index of each cell)."""
    nk = kept.shape[0]
    cell_start = _bucket_starts(cell_of[:nk], ncells)
    fill = cell_start[:-1].copy()
    order = np.empty(nk, dtype=np.int64)
    new_cell = np.empty(nk, dtype=np.int64)
    for q in range(nk):
        c = cell_of[q]
        order[fill[c]] = kept[q]
        new_cell[fill[c]] = c
        fill[c] += 1
    return order, new_cell, cell_start


@njit(cache=True, error_model="numpy")
def _pairs(x, radius, new_cell, cell_start, nc, periodic, box, skin):
    """The half list (start, j) of the sorted particles: pairs within r_i + r_j + skin, i < j: candidates per
    particle (an upper bound), then the search into each particle's own slot, then the rows packed and sorted."""
    nk = new_cell.shape[0]
    slot = np.empty(nk + 1, dtype=np.int64)
    slot[0] = 0
    count = np.empty(nk, dtype=np.int64)
    _candidates(new_cell, cell_start, nc, periodic, count)
    for i in range(nk):
        slot[i + 1] = slot[i] + count[i]
    found = np.empty(slot[nk], dtype=np.int32)
    _search(x, radius, new_cell, cell_start, nc, periodic, box, skin, slot, found, count)
    new_start = np.empty(nk + 1, dtype=np.int64)
    new_start[0] = 0
    for i in range(nk):
        new_start[i + 1] = new_start[i] + count[i]
    new_j = np.empty(new_start[nk], dtype=np.int32)
    _compact(found, slot, new_start, new_j)
    return new_start, new_j


@njit(cache=True, error_model="numpy")
def rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost, transfer):
    """Rebuild the neighbor list of the first n particles of state s; see the module docstring.

    The particle rows of s are re-ordered in place (lost particles dropped: the survivors fill the first rows).
    lost: a LostParticles record, its count incremented per lost particle; transfer: per history column, the
    factor of a pair whose i and j swap roles. Returns (particles kept, new list).
    """
    x = s.x
    box = hi - lo
    kept = _drop_lost(x, n, lo, hi, periodic, s.pid, step, lost)
    nk = kept.shape[0]
    origin, cell_size, nc = _grid(x, s.radius, kept, lo, box, periodic, skin)
    ncells = nc[0] * nc[1] * nc[2]
    cell_of = np.empty(nk, dtype=np.int64)
    _cells(x, kept, origin, cell_size, nc, cell_of)
    order, new_cell, cell_start = _sort_by_cell(cell_of, kept, ncells)
    reorder(s, order)
    new_start, new_j = _pairs(x, s.radius, new_cell, cell_start, nc, periodic, box, skin)
    m = new_start[nk]
    width = nbr.hist.shape[1]
    new_hist = np.empty((m if width > 0 else 0, width))
    new_live = np.zeros(m, dtype=np.uint8)
    if width > 0:
        _carry_history(order, nbr, new_start, new_j, new_hist, new_live, transfer)
    rstart, rslot = reverse_index(new_start, new_j, nk)
    _copy_positions(x, s.x_build, nk)
    return nk, NeighborList(new_start, new_j, new_hist, rstart, rslot, np.empty((m, nbr.reaction.shape[1])),
                            np.zeros(m, dtype=np.uint8), np.zeros(nk, dtype=np.uint8), new_live,
                            np.zeros(nk, np.uint8), np.zeros(nk, np.int64), np.zeros(2, np.int64))


@njit(cache=True, error_model="numpy")
def tally_overlap(overlap, smaller_radius, ratio_limit, n_contacts, n_large, worst):
    """One pair's overlap (m) added to the (contacts, contacts above ratio_limit, largest ratio) so far."""
    if overlap > 0.0:
        n_contacts += 1
        ratio = overlap / smaller_radius
        worst = max(worst, ratio)
        if ratio > ratio_limit:
            n_large += 1
    return n_contacts, n_large, worst


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
            n_contacts, n_large, worst = tally_overlap(radius[i] + radius[j] - r, min(radius[i], radius[j]),
                                                       ratio_limit, n_contacts, n_large, worst)
    return n_contacts, n_large, worst
