"""All cores, same answers: thread count and neighbor lists (issue 11).

The harness compares engine versions; the number of cores must never change a verdict. A scene with contact
history, cohesion, rolling friction, walls and periodic axes runs as a program with 1 and with 2 threads (the
parallel loops forced on however small the scene is) and must write the same bytes. The neighbor list is
checked against brute force on random, periodic, polydisperse particles, after re-ordering and particle loss,
with the contact history following its pairs.
"""
import filecmp
import json

import numpy as np
import pytest

from conftest import domain, engine_program, gravity, interaction, material, model, plane, run, timestep

#: 400 polydisperse spheres poured onto a floor in a box periodic along x and y, next to a pillar (a cylinder
#: wall), one sphere shot out of the top (lost at a rebuild)
SCENE = [domain((-0.015, -0.015, -0.01), (0.015, 0.015, 0.08), periodic=(True, True, False)),
         material(y=5e6, nu=0.45, rho=2500), interaction(e=0.5, mu=0.3, rolling_friction=0.05,
                                                         cohesion_energy_density=2e4),
         model("hertz", "history", cohesion="sjkr", rolling="epsd2"), plane("floor", "z", 0.0),
         {"command": "create", "object": "wall", "name": "pillar", "shape": "cylinder", "center": [0.01, 0],
          "radius": 0.003, "side": "outside", "type": 1}] + gravity() + [
    {"command": "create", "object": "random_packing", "type": 1, "count": 400, "seed": 11, "radius_min": 0.0012,
     "radius_max": 0.0018, "region": {"shape": "box", "lo": [-0.015, -0.015, 0.0], "hi": [0.005, 0.015, 0.07]}},
    {"command": "create", "object": "particle", "type": 1, "radius": 0.001, "position": [0.01, 0.01, 0.075],
     "velocity": [0, 0, 3.0]},
    timestep(2e-5),
    {"command": "set", "property": "thermo", "every": 500,
     "columns": ["ke", "rke", "contacts", "max_overlap", "wall_fz[floor]", "wall_fx[pillar]", "com_z"]},
    {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": 3000},
    {"command": "fix", "name": "dump"},
    {"command": "create", "object": "modifier", "name": "track", "kind": "print", "every": 50,
     "file": "track.csv", "quantities": ["x[7]", "vz[7]", "omegay[7]", "fz[42]"]},
    {"command": "fix", "name": "track"}, run(6000)]


def engine(folder, *args, env=None):
    return engine_program(folder, SCENE, *args, env=env)


@pytest.mark.parametrize("threads", [2, 3])
def test_thread_count_never_changes_the_bytes(tmp_path, threads):
    # 3 threads: the boundary band of the pair pass (engine/neighbor.py boundary_band) has two borders, and a
    # particle may be listed from two earlier shares
    one = engine(tmp_path / "one", env={"NUMBA_NUM_THREADS": "1"})
    two = engine(tmp_path / "two", "-threads", str(threads))
    assert one.returncode == 0, one.stderr
    assert two.returncode == 0, two.stderr
    assert "; threads 1 (" in one.stdout and f"; threads {threads} (" in two.stdout
    assert json.loads((tmp_path / "two" / "timing.json").read_text())["threads"] == threads
    files = ["thermo.csv", "track.csv", "post/particles_0.vtp", "post/particles_3000.vtp",
             "post/particles_6000.vtp"]
    for name in files:
        assert filecmp.cmp(tmp_path / "one" / name, tmp_path / "two" / name, shallow=False), name
    rows = (tmp_path / "one" / "thermo.csv").read_text().splitlines()
    header = rows[0].split(",")
    last = dict(zip(header, rows[-1].split(",")))
    # a bed with contacts on the floor, against the pillar, and one sphere lost
    assert int(last["contacts"]) > 300 and float(last["wall_fz[floor]"]) < 0 and last["atoms"] == "400"
    assert any(float(r.split(",")[header.index("wall_fx[pillar]")]) != 0 for r in rows[1:])


def test_bad_thread_count_is_bad_input(tmp_path):
    proc = engine(tmp_path, "-threads", "zero")
    assert proc.returncode == 2 and proc.stderr.startswith("ERROR: -threads needs a whole number")


# ---------------------------------------------------------------- the neighbor list against brute force

def brute_force_pairs(x, radius, pid, lo, hi, periodic, skin) -> set:
    """Pairs (smaller id, larger id) within r_i + r_j + skin, minimum image along periodic axes."""
    box = hi - lo
    d = x[:, None, :] - x[None, :, :]
    for a in range(3):
        if periodic[a]:
            d[:, :, a] -= box[a] * np.rint(d[:, :, a] / box[a])
    cut = radius[:, None] + radius[None, :] + skin
    close = np.sum(d * d, axis=2) < cut * cut
    i, j = np.nonzero(np.triu(close, k=1))
    return {(min(a, b), max(a, b)) for a, b in zip(pid[i].tolist(), pid[j].tolist())}


def random_state(rng, n, lo, hi, outside=0):
    from engine import state as particle_state

    x = lo + rng.random((n, 3)) * (hi - lo)
    x[:outside, 2] = hi[2] + 0.01  # these leave the fixed z range: lost at the rebuild
    radius = 0.004 + 0.006 * rng.random(n)
    return particle_state.append(particle_state.empty(1, 3), x=x, radius=radius, mass=np.ones(n),
                                 pid=np.arange(1, n + 1), x_build=x.copy(),
                                 v=rng.standard_normal((n, 3)), wall_hist=np.zeros((n, 1, 3)))


def listed_pairs(state, nbr, n) -> set:
    pairs = set()
    for i in range(n):
        row = nbr.j[nbr.start[i]:nbr.start[i + 1]]
        assert np.all(np.diff(row) > 0) and (len(row) == 0 or row[0] > i)  # half list, j increasing
        pairs.update((min(state.pid[i], state.pid[j]), max(state.pid[i], state.pid[j])) for j in row.tolist())
    return pairs


@pytest.mark.parametrize("periodic", [(False, False, False), (True, True, False), (True, True, True)])
def test_neighbor_list_matches_brute_force_after_reordering_and_loss(periodic):
    import numba

    from engine import state as particle_state
    from engine.neighbor import empty_list, lost_record, rebuild

    rng = np.random.default_rng(5)
    lo, hi = np.array([-0.1, -0.1, -0.1]), np.array([0.1, 0.12, 0.1])
    periodic = np.array(periodic)
    skin = 0.003
    n = 600
    results = []
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        s = random_state(np.random.default_rng(5), n, lo, hi, outside=0 if periodic[2] else 7)
        lost = lost_record(n)
        kept, nbr = rebuild(s, n, empty_list(3), lo, hi, periodic, skin, 1, lost, -np.ones(3))
        s = particle_state.trimmed(s, kept)
        expected_lost = 0 if periodic[2] else 7
        assert kept == n - expected_lost and lost.count[0] == expected_lost
        assert sorted(lost.ids[:expected_lost].tolist()) == list(range(1, expected_lost + 1))
        assert listed_pairs(s, nbr, kept) == brute_force_pairs(s.x, s.radius, s.pid, lo, hi, periodic, skin)
        # every field moved with its particle
        assert np.array_equal(np.sort(s.pid), np.arange(expected_lost + 1, n + 1))
        assert np.array_equal(s.x_build, s.x) and np.all(s.mass == 1.0)
        # the reaction rows of each partner p are the pairs (i, p), in increasing i
        pair_of_row = np.empty(len(nbr.j), dtype=np.int64)
        pair_of_row[nbr.rslot] = np.arange(len(nbr.j))
        for p in range(kept):
            ks = pair_of_row[nbr.rstart[p]:nbr.rstart[p + 1]]
            assert np.all(nbr.j[ks] == p) and np.all(np.diff(ks) > 0)
        assert nbr.rstart[-1] == len(nbr.j) and np.array_equal(np.sort(nbr.rslot), np.arange(len(nbr.j)))
        # history column 0 antisymmetric in (i, j): id_i - id_j (transfer factor -1), column 1 symmetric:
        # id_i + id_j (transfer factor +1); after moving the particles and rebuilding, each pair still holds them
        # for its (possibly swapped) owner
        old_pairs = listed_pairs(s, nbr, kept)
        owner = np.repeat(np.arange(kept), np.diff(nbr.start))
        nbr.hist[:, 0] = s.pid[owner] - s.pid[nbr.j]
        nbr.hist[:, 1] = s.pid[owner] + s.pid[nbr.j]
        nbr.live[:] = 1  # rows written here: the rebuild reads them (engine/neighbor.py NeighborList.live)
        s.x[:kept] += 0.004 * np.random.default_rng(9).standard_normal((kept, 3))
        kept2, nbr2 = rebuild(s, kept, nbr, lo, hi, periodic, skin, 2, lost_record(kept), np.array([-1.0, 1.0, -1.0]))
        s = particle_state.trimmed(s, kept2)
        assert listed_pairs(s, nbr2, kept2) == brute_force_pairs(s.x, s.radius, s.pid, lo, hi, periodic, skin)
        # each row in increasing j (the order of the force sums; the history carry searches the rows)
        for p in range(kept2):
            assert np.all(np.diff(nbr2.j[nbr2.start[p]:nbr2.start[p + 1]]) > 0)
        owner2 = np.repeat(np.arange(kept2), np.diff(nbr2.start))
        for k in range(len(nbr2.j)):
            a, b = s.pid[owner2[k]], s.pid[nbr2.j[k]]
            listed = (min(a, b), max(a, b)) in old_pairs
            assert nbr2.hist[k, 0] == (a - b if listed else 0.0)
            assert nbr2.hist[k, 1] == (a + b if listed else 0.0)
        results.append((s.pid.copy(), s.x.copy(), nbr2.start.copy(), nbr2.j.copy(), nbr2.hist.copy()))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for a, b in zip(*results):
        assert np.array_equal(a, b)  # the same bytes on 1 and 2 threads


@pytest.mark.parametrize("height", [0.03, 0.05, 0.07, 0.2])
def test_neighbor_list_matches_brute_force_with_few_periodic_cells_along_the_last_axis(height):
    """The search walks the neighbor cells along the last axis as runs of consecutive cells (engine/neighbor.py
    `_z_runs`): one cell, two, three (a wrap on either side splits the run) and many, against brute force."""
    from engine.neighbor import _grid, empty_list, lost_record, rebuild

    lo, hi = np.array([-0.1, -0.1, 0.0]), np.array([0.1, 0.1, height])
    periodic = np.array([False, True, True])
    skin = 0.003
    n = 400
    s = random_state(np.random.default_rng(11), n, lo, hi)
    cells = _grid(s.x, s.radius, np.arange(n), lo, hi - lo, periodic, skin)[2][2]
    assert cells == {0.03: 1, 0.05: 2, 0.07: 3}.get(height, cells)
    kept, nbr = rebuild(s, n, empty_list(3), lo, hi, periodic, skin, 1, lost_record(n), -np.ones(3))
    assert kept == n
    pairs = listed_pairs(s, nbr, n)
    assert pairs == brute_force_pairs(s.x, s.radius, s.pid, lo, hi, periodic, skin)
    assert len(pairs) > n // 2  # dense enough that a cell left out would lose pairs


def test_every_thread_gets_an_equal_share_of_the_pair_blocks():
    """The pair pass (engine/kernels.py PAIR_FORCES) takes blocks of at most PAIR_BLOCK particles; OpenMP gives
    each thread one contiguous share of them, so their count is a multiple of the thread count and the shares
    differ by at most one particle per block (blocks of exactly 512 gave one thread of two 5,120 of 10,000)."""
    import numba

    from engine import threads
    from engine.kernels import PAIR_BLOCK
    from engine.neighbor import block_count

    for count in range(1, numba.config.NUMBA_NUM_THREADS + 1):
        assert threads.use(10 ** 6, count) == count
        assert numba.get_parallel_chunksize() == 0  # one share per thread in every other loop too
        assert block_count(0, PAIR_BLOCK) == 0
        for n in (1, 7, 511, 512, 513, 10000, 10001, 99999):
            blocks = block_count(n, PAIR_BLOCK)
            assert blocks % count == 0 and blocks >= count
            sizes = np.diff(np.arange(blocks + 1) * n // blocks)
            assert sizes.sum() == n and sizes.max() <= PAIR_BLOCK and sizes.max() - sizes.min() <= 1
            shares = sizes.reshape(count, -1).sum(axis=1)
            assert shares.max() - shares.min() <= blocks // count
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)


@pytest.mark.parametrize("shares", [1, 2, 3, 5])
def test_the_boundary_band_is_every_particle_listed_from_an_earlier_share(shares):
    """The pair pass' band (engine/neighbor.py boundary_band): exactly the particles p of some listed pair (q, p)
    whose q lies in an earlier thread's share than p, against a brute-force count over every pair; start_band
    computes it for the current thread count, again after a change of it, and sets the band's forces to zero."""
    import numba

    from engine.kernels import PAIR_BLOCK
    from engine.neighbor import block_count, boundary_band, empty_list, lost_record, rebuild, share_start, start_band

    lo, hi = np.array([-0.1, -0.1, -0.1]), np.array([0.1, 0.1, 0.1])
    n = 3000  # several blocks per share
    s = random_state(np.random.default_rng(7), n, lo, hi)
    kept, nbr = rebuild(s, n, empty_list(3), lo, hi, np.zeros(3, dtype=np.bool_), 0.003, 1, lost_record(n),
                        -np.ones(3))
    blocks = (n + PAIR_BLOCK - 1) // PAIR_BLOCK
    blocks = (blocks + shares - 1) // shares * shares  # block_count on `shares` threads
    first = np.array([share_start(t, shares, n, blocks) for t in range(shares + 1)])
    assert first[0] == 0 and first[-1] == n and np.all(np.diff(first) > 0)
    share_of = np.searchsorted(first, np.arange(n), side="right") - 1
    owner = np.repeat(np.arange(n), np.diff(nbr.start))
    expected = np.zeros(n, dtype=np.uint8)
    expected[nbr.j[share_of[owner] < share_of[nbr.j]]] = 1
    assert (shares == 1) == (expected.sum() == 0) and expected.sum() < n // 2
    band, members = np.full(n, 9, np.uint8), np.full(n, -1, np.int64)
    count = boundary_band(nbr.start, nbr.j, n, shares, blocks, band, members)
    assert np.array_equal(band, expected) and np.array_equal(members[:count], np.flatnonzero(expected))
    if shares > numba.config.NUMBA_NUM_THREADS:
        return
    numba.set_num_threads(shares)
    assert block_count(n, PAIR_BLOCK) == blocks
    s.f[:] = 1.0
    s.torque[:] = 1.0
    for _ in range(2):  # the second call keeps the band computed
        start_band(nbr, n, PAIR_BLOCK, s.f, s.torque)
        assert np.array_equal(nbr.band, expected) and list(nbr.shares) == [shares, count]
        assert np.all((s.f == 0.0) == expected[:, None].astype(bool)) and np.all(s.torque[expected == 1] == 0.0)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
