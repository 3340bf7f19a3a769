"""Particles inserted during a run (issue 12): modifier `insert`.

What a scene relies on: the count follows rate x time (mass follows mass_rate x time within one particle), the
radii follow the distribution, inserted particles never overlap anything, the same seed gives the same bytes
on 1 and 2 threads, an insertion leaves the contacts already there (and their tangential history) exactly as
they were, and a restart continues the stream as the long run does.
"""
import filecmp
import math

import numpy as np
import pytest

from conftest import domain, engine_program, gravity, interaction, material, model, plane, printer, read_csv, run, \
    timestep
from engine.insertion import Distribution
from engine.script import Fields

RHO = 2500.0


def region(name, lo, hi):
    return {"command": "create", "object": "region", "name": name, "shape": "box", "lo": list(lo), "hi": list(hi)}


def feed(name="feed", every=100, region_name="fill", **fields):
    spec = {"command": "create", "object": "modifier", "name": name, "kind": "insert", "every": every, "type": 1,
            "region": region_name, "seed": 5}
    spec.update(fields)
    if "radius" not in spec and "radius_distribution" not in spec:
        spec["radius"] = 0.002
    if "rate" not in spec and "mass_rate" not in spec:
        spec["rate"] = 2000
    return [spec, {"command": "fix", "name": name}]


def dump(every, name="dump"):
    return [{"command": "create", "object": "modifier", "name": name, "kind": "vtk", "every": every},
            {"command": "fix", "name": name}]


def read_vtp(path) -> dict:
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    poly = reader.GetOutput()
    data = poly.GetPointData()
    out = {data.GetArrayName(k): vtk_to_numpy(data.GetArray(k)) for k in range(data.GetNumberOfArrays())}
    out["x"] = vtk_to_numpy(poly.GetPoints().GetData()) if poly.GetNumberOfPoints() else np.zeros((0, 3))
    return out


def min_clearance(x, r) -> float:
    """min over pairs of |x_i - x_j| - (r_i + r_j) (m); >= 0 when nothing overlaps."""
    d = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(-1)) - (r[:, None] + r[None, :])
    d[np.diag_indices(len(x))] = np.inf
    return float(d.min())


#: no gravity, particles inserted at rest: they stay where they were put (nothing overlaps, nothing pushes)
STILL = [domain((-0.05, -0.05, -0.05), (0.05, 0.05, 0.05)), material(rho=RHO), interaction(mu=0.3),
         model("hertz", "history"), region("fill", (-0.02, -0.02, -0.02), (0.02, 0.02, 0.02)), timestep(1e-5)]


def test_count_follows_rate_times_time_and_nothing_overlaps(engine_run):
    # 2000/s x 100 steps x 1e-5 s = 2 particles per insertion, at steps 0, 100, ..., 3000: 31 insertions
    scene = STILL + feed(every=100, radius_distribution={"kind": "uniform", "min": 0.0015, "max": 0.0025}) + [
        {"command": "set", "property": "thermo", "every": 500, "columns": ["inserted_count[feed]",
                                                                          "inserted_mass[feed]", "lost"]}] + \
        dump(3000) + [run(3000)]
    code, folder = engine_run(scene)
    assert code == 0
    thermo = read_csv(folder / "thermo.csv")
    steps = thermo["step"]
    expected = np.floor(2000 * (steps + 100) * 1e-5 + 1e-6)
    assert list(thermo["inserted_count[feed]"]) == list(expected) == list(thermo["atoms"])
    assert thermo["atoms"][-1] == 62 and list(thermo["lost"]) == [0] * len(steps)
    p = read_vtp(folder / "post" / "particles_3000.vtp")
    assert list(p["id"]) == list(range(1, 63))  # ids continue, never reused
    assert min_clearance(p["x"], p["radius"]) >= 0.0
    # entirely inside the region
    assert np.all(np.abs(p["x"]) + p["radius"][:, None] <= 0.02)
    mass = RHO * 4 / 3 * math.pi * p["radius"] ** 3
    assert thermo["inserted_mass[feed]"][-1] == pytest.approx(mass.sum(), rel=1e-12)


def test_a_full_region_carries_over_and_warns_once(engine_run):
    # room for a few dozen spheres of 4 mm in a 2 cm cube: the rest is carried over, one warning
    scene = [*STILL[:4], region("fill", (0, 0, 0), (0.02, 0.02, 0.02)), timestep(1e-5)] + \
        feed(every=100, rate=50000, radius=0.004, max_attempts=50) + dump(500) + [run(500)]
    code, folder = engine_run(scene)
    assert code == 0
    log = (folder / "log.dem").read_text()
    assert log.count("insert modifier 'feed' placed only") == 1
    assert "the rest is carried over" in log
    p = read_vtp(folder / "post" / "particles_500.vtp")
    assert 5 < len(p["id"]) < 300 and min_clearance(p["x"], p["radius"]) >= 0.0


def test_total_caps_the_count(engine_run):
    scene = STILL + feed(every=100, total=7) + [{"command": "set", "property": "thermo", "every": 100}, run(1000)]
    code, folder = engine_run(scene)
    assert code == 0
    assert list(read_csv(folder / "thermo.csv")["atoms"]) == [2, 4, 6, 7, 7, 7, 7, 7, 7, 7, 7]


def test_start_delays_the_first_insertion(engine_run):
    scene = STILL + feed(every=100, start=250) + [{"command": "set", "property": "thermo", "every": 100}, run(500)]
    code, folder = engine_run(scene)
    assert code == 0
    assert list(read_csv(folder / "thermo.csv")["atoms"]) == [0, 0, 0, 2, 4, 6]


def test_mass_rate_is_honoured_within_one_particle(engine_run):
    radii, fractions = [0.001, 0.002, 0.003], [0.2, 0.3, 0.5]
    scene = STILL + feed(every=200, mass_rate=0.2, total_mass=0.004,
                         radius_distribution={"kind": "discrete", "radii": radii, "mass_fractions": fractions}) + [
        {"command": "set", "property": "thermo", "every": 200, "columns": ["inserted_mass[feed]", "mass"
                                                                           "[type=1]"]}, run(4000)]
    code, folder = engine_run(scene)
    assert code == 0
    thermo = read_csv(folder / "thermo.csv")
    target = np.minimum(0.2 * (thermo["step"] + 200) * 1e-5, 0.004)
    biggest = RHO * 4 / 3 * math.pi * 0.003 ** 3
    got = thermo["inserted_mass[feed]"]
    assert np.all(got <= target + 1e-15) and np.all(target - got < biggest)
    assert np.allclose(got, thermo["mass[type=1]"], rtol=1e-12, atol=0)
    assert got[-1] > 0.004 - biggest


def test_discrete_mass_fractions_of_2000_particles(engine_run):
    radii, fractions = [0.0008, 0.0012, 0.0016], [0.3, 0.2, 0.5]
    scene = [domain((-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), material(rho=RHO), interaction(), model(),
             region("fill", (-0.1, -0.1, -0.1), (0.1, 0.1, 0.1)), timestep(1e-5)] + \
        feed(every=100, rate=200000,
             radius_distribution={"kind": "discrete", "radii": radii, "mass_fractions": fractions}) + dump(900) + \
        [run(900)]
    code, folder = engine_run(scene)
    assert code == 0
    r = read_vtp(folder / "post" / "particles_900.vtp")["radius"]
    assert len(r) == 2000 and set(np.unique(r)) == set(radii)
    mass = r ** 3
    for radius, fraction in zip(radii, fractions):
        assert mass[r == radius].sum() / mass.sum() == pytest.approx(fraction, abs=0.03)


def _distribution(spec):
    fields = Fields(spec, "test")
    fields.used = set()
    dist = Distribution(fields, "radius_distribution")
    fields.finish()
    return dist


@pytest.mark.parametrize("spec, mean, sd", [
    ({"kind": "uniform", "min": 0.001, "max": 0.003}, 0.002, 0.002 / math.sqrt(12)),
    ({"kind": "normal", "mean": 0.002, "sd": 0.0002, "min": 0.001, "max": 0.003}, 0.002, 0.0002),
    ({"kind": "lognormal", "median": 0.002, "sigma": 0.1, "min": 0.0001, "max": 0.1},
     0.002 * math.exp(0.005), 0.002 * math.sqrt((math.exp(0.01) - 1) * math.exp(0.01))),
])
def test_continuous_distributions_sample_statistics(spec, mean, sd):
    r = _distribution(spec).sample(np.random.Generator(np.random.PCG64(1)), 20000)
    assert r.mean() == pytest.approx(mean, rel=0.01) and r.std() == pytest.approx(sd, rel=0.03)
    assert r.min() >= spec["min"] and r.max() <= spec["max"]


def test_truncation_is_honoured():
    r = _distribution({"kind": "normal", "mean": 0.002, "sd": 0.001, "min": 0.0015, "max": 0.0025}).sample(
        np.random.Generator(np.random.PCG64(2)), 5000)
    assert len(r) == 5000 and r.min() >= 0.0015 and r.max() <= 0.0025


def test_same_seed_same_bytes_other_seed_other_particles(engine_run):
    def scene(seed):
        return STILL + feed(every=100, seed=seed, radius_distribution={"kind": "normal", "mean": 0.002,
                                                                       "sd": 0.0003, "min": 0.001, "max": 0.003}) + \
            dump(1000) + [run(1000)]
    for sub, seed in (("a", 3), ("b", 3), ("c", 4)):
        assert engine_run(scene(seed), sub=sub)[0] == 0
    a, b, c = (engine_run.folder / s / "post" / "particles_1000.vtp" for s in "abc")
    assert filecmp.cmp(a, b, shallow=False)
    assert not np.array_equal(read_vtp(a)["x"], read_vtp(c)["x"])


#: two spheres in an oblique collision with friction (tangential history), particle 1 below particle 2 on every
#: axis throughout, so that their order after any neighbor rebuild is the same; no gravity
COLLISION = [domain((-0.3, -0.3, -0.3), (0.3, 0.3, 0.3)), material(rho=RHO), interaction(e=0.7, mu=0.5),
             model("hertz", "history"), timestep(1e-5),
             {"command": "create", "object": "particle", "type": 1, "radius": 0.01, "position": [0, 0, 0],
              "velocity": [1, 0, 0], "omega": [0, 0, 0]},
             {"command": "create", "object": "particle", "type": 1, "radius": 0.01,
              "position": [0.025, 0.005, 0.005], "velocity": [-1, 0, 0], "omega": [0, 0, 0]}]
TRACK = [f"{q}[{i}]" for i in (1, 2) for q in ("x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz",
                                                "fx", "fy", "fz")]


def test_an_insertion_leaves_existing_contacts_and_their_history_alone(engine_run):
    # the far particle arrives at step 400, in the middle of the contact (about steps 310-480): the neighbor
    # list is rebuilt for it, the pair (1, 2) keeps its shear history, and a far particle pushes nobody
    far = [region("far", (0.15, 0.15, 0.15), (0.25, 0.25, 0.25))] + \
        feed(every=400, start=400, rate=1000, total=1, region_name="far", radius=0.01)
    for sub, extra in (("with", far), ("without", [])):
        # two runs, the insertion at the end of the first: the second run must not evaluate the forces (and
        # advance the shear history) again before its first step
        code, _ = engine_run(COLLISION + extra + printer(1, TRACK + ["contacts", "atoms"]) + [run(400), run(600)],
                             sub=sub)
        assert code == 0
    with_far = read_csv(engine_run.folder / "with" / "series.csv")
    without = read_csv(engine_run.folder / "without" / "series.csv")
    assert list(with_far["atoms"][399:402]) == [2, 3, 3]
    touching = np.nonzero(without["contacts"])[0]
    assert touching[0] < 400 < touching[-1]  # the insertion falls inside the contact
    assert np.max(np.abs(without["omegaz[1]"])) > 1.0  # friction turned them: history is in play
    for q in TRACK:
        assert np.array_equal(with_far[q], without[q]), q


def test_restart_after_insertions_continues_the_stream(engine_run):
    base = [domain((-0.03, -0.03, -0.01), (0.03, 0.03, 0.1)), material(rho=RHO), interaction(mu=0.3),
            model("hertz", "history"), plane("floor", "z", 0.0)] + [
        plane(n, a, p) for n, a, p in (("w1", "x", -0.03), ("w2", "x", 0.03), ("w3", "y", -0.03), ("w4", "y", 0.03))]
    declare = base[1:4] + gravity() + [region("fill", (-0.025, -0.025, 0.05), (0.025, 0.025, 0.09))]
    insert = feed(every=300, rate=20000, radius_distribution={"kind": "uniform", "min": 0.0015, "max": 0.002},
                  velocity=[0, 0, -0.5])
    thermo = {"command": "set", "property": "thermo", "every": 300,
              "columns": ["inserted_count[feed]", "inserted_mass[feed]", "contacts", "com_z"]}
    long_run = base + gravity() + [declare[-1], timestep(1e-5)] + insert + [thermo] + dump(3000) + [
        {"command": "create", "object": "modifier", "name": "save", "kind": "restart", "every": 1500,
         "file": "bed_{step}.npz"}, {"command": "fix", "name": "save"}, run(3000)]
    code, long_folder = engine_run(long_run, sub="long")
    assert code == 0
    for order in ("before", "after"):
        restore = {"command": "set", "property": "restart", "file": str(long_folder / "bed_1500.npz")}
        middle = insert + [restore] if order == "before" else [restore] + insert
        code, folder = engine_run(declare + middle + [thermo] + dump(3000) + [run(1500)], sub=order)
        assert code == 0, (folder / "log.dem").read_text()[-500:]
        assert filecmp.cmp(long_folder / "post" / "particles_3000.vtp", folder / "post" / "particles_3000.vtp",
                           shallow=False), order
        long_rows = (long_folder / "thermo.csv").read_text().splitlines()
        rows = (folder / "thermo.csv").read_text().splitlines()
        assert rows[1:] == long_rows[-len(rows) + 1:], order
    p = read_vtp(long_folder / "post" / "particles_3000.vtp")
    assert len(p["id"]) == 20000 * 3300 * 1e-5 and list(p["id"]) == list(range(1, len(p["id"]) + 1))


@pytest.mark.parametrize("fields, message", [
    ({"type": 9}, "field 'type' names unknown material type 9"),
    ({"region": "nowhere"}, "field 'region' names no region 'nowhere'"),
    ({"mass_rate": 1.0}, "field 'rate' give either 'rate' (particles/s) or 'mass_rate' (kg/s)"),
    ({"total": 5, "total_mass": 1.0}, "field 'total' give at most one of"),
    ({"radius_distribution": {"kind": "uniform", "min": 0.001, "max": 0.002}}, "field 'radius' give either"),
    ({"radius": None, "radius_distribution": {"kind": "uniform", "min": 0.003, "max": 0.002}},
     "radius_distribution: field 'max' must be >= min"),
    ({"radius": None, "radius_distribution": {"kind": "normal", "mean": 0.002, "sd": 1e-5, "min": 0.003,
                                              "max": 0.004}}, "holds almost none of the normal distribution"),
    ({"radius": None, "radius_distribution": {"kind": "discrete", "radii": [0.001, 0.002],
                                              "mass_fractions": [1.0]}}, "must have one entry per radius"),
    ({"radius": None, "radius_distribution": {"kind": "discrete", "radii": [0.001, -1], "mass_fractions": [1, 1]}},
     "field 'radii' must be a non-empty list of positive numbers"),
    ({"radius": None, "radius_distribution": {"kind": "gamma"}}, "field 'kind' must be one of"),
    ({"radius": 0.05}, "field 'region' is too small for a sphere of radius 0.05 m"),
    ({"seed": None}, "field 'seed' is missing"),
    ({"colour": "red"}, "field 'colour' is not a field of this command"),
])
def test_bad_insert_fields(engine_run, fields, message):
    spec = feed()
    spec[0].update(fields)
    for key in [k for k, v in fields.items() if v is None]:
        spec[0].pop(key)
    code, folder = engine_run(STILL + spec)
    assert code == 2
    last = (folder / "log.dem").read_text().splitlines()[-1]
    assert last.startswith("ERROR: scene.json: command 7 (create modifier)") and message in last, last


def test_a_region_beyond_the_domain_is_refused_before_the_run(engine_run):
    scene = STILL[:4] + [region("fill", (0.0, 0.0, 0.0), (0.1, 0.02, 0.02)), timestep(1e-5)] + feed() + [run(10)]
    code, folder = engine_run(scene)
    assert code == 2
    last = (folder / "log.dem").read_text().splitlines()[-1]
    assert ("command 9 (run): field 'steps' cannot run: modifier 'feed' inserts into a region reaching beyond "
            "the domain along x") in last


def test_a_type_without_interaction_is_refused_before_the_run(engine_run):
    scene = STILL + [material(2)] + feed(type=2) + [run(10)]
    code, folder = engine_run(scene)
    assert code == 2
    assert "no interaction for material types 2 and 2" in (folder / "log.dem").read_text().splitlines()[-1]


# ---------------------------------------------------------------- the same bytes on 1 and 2 threads

#: a hopper-like stream: particles fed at the top of a walled box fall onto an outlet-drained floor
STREAM = [domain((-0.02, -0.02, -0.01), (0.02, 0.02, 0.07)), material(y=5e6, nu=0.45, rho=RHO),
          interaction(e=0.5, mu=0.3, rolling_friction=0.05), model("hertz", "history", rolling="cdt"),
          plane("floor", "z", 0.0)] + [plane(n, a, p) for n, a, p in (("w1", "x", -0.02), ("w2", "x", 0.02),
                                                                       ("w3", "y", -0.02), ("w4", "y", 0.02))] + \
    gravity() + [region("fill", (-0.018, -0.018, 0.03), (0.018, 0.018, 0.06)),
                 {"command": "create", "object": "region", "name": "hole", "shape": "cylinder",
                  "center": [0, 0], "radius": 0.006, "z": [-0.01, 0.003]}] + \
    feed(every=500, rate=20000, velocity=[0, 0, -1.0],
         radius_distribution={"kind": "discrete", "radii": [0.0012, 0.0016], "mass_fractions": [0.4, 0.6]}) + \
    [{"command": "create", "object": "modifier", "name": "drain", "kind": "outlet", "every": 200,
      "region": "hole"}, {"command": "fix", "name": "drain"}, timestep(1e-5),
     {"command": "set", "property": "thermo", "every": 500,
      "columns": ["inserted_count[feed]", "removed_count[drain]", "removed_mass[drain]", "lost", "contacts",
                  "ke[region=hole]"]}] + dump(4000) + [run(8000)]


def _engine(folder, *args, env=None):
    return engine_program(folder, STREAM, *args, env=env)


@pytest.mark.slow
def test_insertion_and_outlet_give_the_same_bytes_on_any_thread_count(tmp_path):
    one = _engine(tmp_path / "one", env={"NUMBA_NUM_THREADS": "1"})
    two = _engine(tmp_path / "two", "-threads", "2")
    assert one.returncode == 0, one.stderr
    assert two.returncode == 0, two.stderr
    assert "; threads 2 (" in two.stdout
    for name in ("thermo.csv", "post/particles_4000.vtp", "post/particles_8000.vtp"):
        assert filecmp.cmp(tmp_path / "one" / name, tmp_path / "two" / name, shallow=False), name
    last = read_csv(tmp_path / "one" / "thermo.csv")
    assert last["inserted_count[feed]"][-1] == 1700  # 20000/s x 8500 steps x 1e-5 s
    assert "placed only" not in (tmp_path / "one" / "log.dem").read_text()
    assert last["removed_count[drain]"][-1] > 0 and last["lost"][-1] == 0 and last["contacts"][-1] > 50
    assert last["atoms"][-1] == last["inserted_count[feed]"][-1] - last["removed_count[drain]"][-1]
