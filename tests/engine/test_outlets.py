"""Outlets (issue 12): modifier `outlet` removes the particles whose centre is in its region, and
engine/particle_set.py keeps the neighbor list and the contact history of every surviving pair.

A removal is not a loss: `lost` (and the log's total) counts only particles that left the domain, so a scene
with an outlet checks thermo.lost, and removed_count / removed_mass say what the outlet took, exactly.
"""
import math

import numpy as np
import pytest

from conftest import domain, gravity, interaction, material, model, printer, read_csv, run, timestep
from engine import particle_set
from engine import state as particle_state
from engine.neighbor import NeighborList, reverse_index, stale_band
from engine.mesh import MeshList
from test_insertion_stream import COLLISION, TRACK, region

RHO = 2500.0
G = 9.81
DT = 1e-4


def outlet(name="drain", every=10, region_name="sink"):
    return [{"command": "create", "object": "modifier", "name": name, "kind": "outlet", "every": every,
             "region": region_name}, {"command": "fix", "name": name}]


def test_free_falling_particles_are_removed_exactly(engine_run):
    # particle k falls from rest at h_k and its centre reaches z = 0 between steps 10 m_k + 4 and 10 m_k + 5
    # (velocity Verlet is exact for a constant force: z_n = h - g (n dt)^2 / 2); the outlet, every 10 steps,
    # takes it at step 10 m_k + 10
    crossing = [10 * m + 4.5 for m in (3, 7, 8, 12, 20, 21, 35)]
    heights = [0.5 * G * (c * DT) ** 2 for c in crossing]
    radii = [0.004 + 0.0005 * k for k in range(len(heights))]
    particles = [{"command": "create", "object": "particle", "type": 1, "radius": r, "position": [0.05 * k, 0, h]}
                 for k, (r, h) in enumerate(zip(radii, heights))]
    scene = [domain((-0.1, -0.1, -0.5), (0.5, 0.1, 0.5)), material(rho=RHO), interaction(), model()] + \
        gravity((0, 0, -G)) + particles + [region("sink", (-0.1, -0.1, -0.5), (0.5, 0.1, 0.0)), timestep(DT)] + \
        outlet() + printer(10, ["removed_count[drain]", "removed_mass[drain]", "atoms", "lost"]) + [
        {"command": "set", "property": "thermo", "every": 100, "columns": ["lost"]}, run(400)]
    code, folder = engine_run(scene)
    assert code == 0
    series = read_csv(folder / "series.csv")
    masses = [RHO * 4.0 / 3.0 * math.pi * r ** 3 for r in radii]
    for step, count, mass, atoms, lost in zip(series["step"], series["removed_count[drain]"],
                                              series["removed_mass[drain]"], series["atoms"], series["lost"]):
        gone = [k for k, c in enumerate(crossing) if c < step]
        expected_mass = 0.0
        for k in gone:  # one particle per removal step: the outlet adds them in this order
            expected_mass += masses[k]
        assert (count, atoms, lost) == (len(gone), len(heights) - len(gone), 0), step
        assert mass == expected_mass, step
    log = (folder / "log.dem").read_text()
    assert log.splitlines()[-1].startswith(f"total: 400 steps, 0 particles, 0 lost")  # empty, and no failure
    assert "left the fixed domain" not in log
    thermo = read_csv(folder / "thermo.csv")
    assert list(thermo["atoms"]) == [7, 4, 3, 1, 0] and list(thermo["lost"]) == [0] * 5


def test_a_removed_particles_partner_keeps_its_history(engine_run):
    # particle 3 flies far from the colliding pair (1, 2) into the outlet's region (about step 390, inside the
    # contact of steps 310-480): removed, the pair's shear history and trajectories are those of a scene
    # without particle 3 at all, to the byte
    far = [{"command": "create", "object": "particle", "type": 1, "radius": 0.01, "position": [0.15, 0.15, 0.15],
            "velocity": [0, 0, 1]}, region("sink", (0.1, 0.1, 0.1539), (0.2, 0.2, 0.2))] + outlet(every=20)
    for sub, extra in (("with", far), ("without", [])):
        # two runs, the removal at the end of the first (step 400)
        code, _ = engine_run(COLLISION + extra + printer(1, TRACK + ["contacts", "atoms", "lost"])
                             + [run(400), run(600)], sub=sub)
        assert code == 0
    with_far = read_csv(engine_run.folder / "with" / "series.csv")
    without = read_csv(engine_run.folder / "without" / "series.csv")
    removed_at = int(with_far["step"][np.nonzero(with_far["atoms"] == 2)[0][0]])
    touching = np.nonzero(without["contacts"])[0]
    assert touching[0] < removed_at < touching[-1] and removed_at == 400
    assert np.max(np.abs(without["omegaz[1]"])) > 1.0
    assert not with_far["lost"].any()
    for q in TRACK:
        assert np.array_equal(with_far[q], without[q]), q


def test_an_outlet_with_an_unknown_region_is_bad_input(engine_run):
    code, folder = engine_run(COLLISION + outlet(region_name="nowhere"))
    assert code == 2
    assert "command 8 (create modifier): field 'region' names no region 'nowhere'" in \
        (folder / "log.dem").read_text().splitlines()[-1]


# ---------------------------------------------------------------- particle_set on a neighbor list directly

class _Scene:
    """What particle_set reads of a simulation: state, neighbor list, mesh contact list, dirty."""

    def __init__(self, n, pairs, width, rng):
        self.state = particle_state.append(
            particle_state.empty(), x=rng.random((n, 3)), radius=np.full(n, 0.01), pid=np.arange(1, n + 1),
            x_build=rng.random((n, 3)))
        pairs = sorted(pairs)
        start = np.zeros(n + 1, dtype=np.int64)
        for i, _ in pairs:
            start[i + 1] += 1
        start = np.cumsum(start)
        j = np.array([b for _, b in pairs], dtype=np.int32)
        rstart, rslot = reverse_index(start, j, n)
        hist = rng.random((len(j), width))
        reaction = np.empty((len(j), 3))
        reaction[rslot] = rng.random((len(j), 3))
        touch = rng.integers(0, 2, len(j)).astype(np.uint8)
        self.nbr = NeighborList(start, j, hist, rstart, rslot, reaction, touch, np.zeros(n, dtype=np.uint8),
                                rng.integers(0, 2, len(j)).astype(np.uint8), **stale_band(n))
        # particle-triangle contacts (engine/mesh.py): 0-3 triangles per particle, each with its history
        counts = rng.integers(0, 4, n)
        mesh_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.mesh_nbr = MeshList(mesh_start, rng.integers(0, 50, mesh_start[-1]).astype(np.int32),
                                 rng.random((mesh_start[-1], width)), np.zeros(mesh_start[-1], dtype=np.uint8),
                                 self.state.pid.copy())
        self.dirty = False

    @property
    def n(self):
        return particle_state.count(self.state)


def _pairs_by_id(scene):
    """{(id_i, id_j): (history row, reaction row, touching, live byte)} of a half list."""
    out = {}
    pid = scene.state.pid
    nbr = scene.nbr
    for i in range(scene.n):
        for k in range(nbr.start[i], nbr.start[i + 1]):
            q = nbr.rslot[k]
            out[(pid[i], pid[nbr.j[k]])] = (tuple(nbr.hist[k]), tuple(nbr.reaction[q]), int(nbr.touch[q]),
                                            int(nbr.live[k]))
    return out


def _mesh_rows_by_id(scene):
    """{particle id: (triangles, history rows)} of the particle-triangle list."""
    m = scene.mesh_nbr
    assert len(m.start) == scene.n + 1 and m.start[-1] == len(m.tri) == len(m.hist)
    assert np.array_equal(m.owner, scene.state.pid[:len(m.owner)])
    return {int(scene.state.pid[i]): (tuple(m.tri[m.start[i]:m.start[i + 1]]),
                                      tuple(map(tuple, m.hist[m.start[i]:m.start[i + 1]])))
            for i in range(scene.n)}


def _check_list(scene):
    nbr = scene.nbr
    assert len(nbr.start) == scene.n + 1 and nbr.start[0] == 0 and nbr.start[-1] == len(nbr.j)
    for i in range(scene.n):
        row = nbr.j[nbr.start[i]:nbr.start[i + 1]]
        assert np.all(row > i) and np.all(np.diff(row) > 0)
    rstart, rslot = reverse_index(nbr.start, nbr.j, scene.n)
    assert np.array_equal(rstart, nbr.rstart) and np.array_equal(rslot, nbr.rslot)
    assert nbr.j.dtype == np.int32 and nbr.hist.shape[0] == len(nbr.j)


@pytest.mark.parametrize("seed", range(5))
def test_remove_keeps_the_pairs_of_survivors_with_their_history(seed):
    rng = np.random.default_rng(seed)
    n = 60
    pairs = {(a, b) for a, b in rng.integers(0, n, (300, 2)) if a < b}
    scene = _Scene(n, pairs, 3, rng)
    before = _pairs_by_id(scene)
    mesh_before = _mesh_rows_by_id(scene)
    keep = rng.random(n) < 0.7
    kept_ids = scene.state.pid[keep]
    x_build = scene.state.x_build[keep].copy()
    assert particle_set.remove(scene, keep) == n - keep.sum()
    _check_list(scene)
    assert list(scene.state.pid) == list(kept_ids)  # order kept
    assert np.array_equal(scene.state.x_build, x_build)  # no rebuild forced
    expected = {p: v for p, v in before.items() if p[0] in set(kept_ids) and p[1] in set(kept_ids)}
    assert _pairs_by_id(scene) == expected
    assert _mesh_rows_by_id(scene) == {p: rows for p, rows in mesh_before.items() if p in set(kept_ids)}


def test_insert_appends_particles_without_pairs_that_force_a_rebuild():
    rng = np.random.default_rng(9)
    scene = _Scene(20, {(0, 3), (2, 5), (5, 19), (3, 4)}, 6, rng)
    before = _pairs_by_id(scene)
    particle_set.insert(scene, x=rng.random((4, 3)), radius=np.full(4, 0.01), pid=np.arange(21, 25))
    _check_list(scene)
    assert scene.n == 24 and _pairs_by_id(scene) == before
    assert all(rows == ((), ()) for p, rows in _mesh_rows_by_id(scene).items() if p > 20)
    far = scene.state.x_build[20:]
    assert np.all(far == particle_set.FAR)
    # the drift pass' criterion (kernels.py DRIFT): moved more than skin/2 for any skin, and finite
    d2 = ((scene.state.x[20:] - far) ** 2).sum(1)
    assert np.all(np.isfinite(d2)) and np.all(d2 > 0.25 * 1.0 ** 2)


def test_before_the_first_run_only_the_state_changes():
    rng = np.random.default_rng(1)
    scene = _Scene(5, {(0, 1)}, 3, rng)
    scene.dirty = True  # the run's set-up will build the list
    nbr = scene.nbr
    particle_set.insert(scene, x=rng.random((2, 3)), radius=np.full(2, 0.01), pid=np.arange(6, 8))
    particle_set.remove(scene, np.array([True, False, True, True, True, True, False]))
    assert scene.nbr is nbr and list(scene.state.pid) == [1, 3, 4, 5, 6]
