"""Outputs, restart, determinism, guards and the effects-only-when-named rule."""
import filecmp
import json
import math

import numpy as np
import pytest

from conftest import (domain, gravity, interaction, material, model, particle, plane, printer, read_csv, run,
                      timestep)
from engine.kernels import Combination, generate_source
from engine.quantities import overlaps
from engine.simulation import Log, Simulation


def pouring_scene(seed=5, steps=600, extra=()):
    walls = [plane("floor", "z", 0.0)] + [plane(f"{a}{s}", a, s * 0.02) for a in "xy" for s in (-1, 1)]
    return [domain((-0.03, -0.03, -0.01), (0.03, 0.03, 0.08)), material(), interaction(e=0.5, mu=0.3),
            model("hertz", "history")] + walls + gravity() + [
        {"command": "create", "object": "random_packing", "type": 1, "count": 60, "seed": seed,
         "radius_min": 0.002, "radius_max": 0.003,
         "region": {"shape": "cylinder", "center": [0, 0], "radius": 0.018, "z": [0.0, 0.06]}},
        timestep(2e-5), {"command": "set", "property": "thermo", "every": 100, "columns": ["com_z", "contacts"]},
        {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": 300},
        {"command": "fix", "name": "dump"}, *extra, run(steps)]


def test_same_seed_gives_byte_identical_outputs(engine_run):
    code_a, a = engine_run(pouring_scene(), sub="a")
    code_b, b = engine_run(pouring_scene(), sub="b")
    code_c, c = engine_run(pouring_scene(seed=6), sub="c")
    assert code_a == code_b == code_c == 0
    assert read_csv(a / "thermo.csv")["contacts"][0] == 0  # the packing has no overlaps
    for name in ("thermo.csv", "post/particles_300.vtp", "post/particles_600.vtp"):
        assert filecmp.cmp(a / name, b / name, shallow=False), name
    assert not filecmp.cmp(a / "thermo.csv", c / "thermo.csv", shallow=False)


def test_vtk_dump_reads_back(engine_run):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    code, folder = engine_run(pouring_scene(extra=printer(600, ["x[7]", "vz[7]", "omegax[7]"])))
    assert code == 0
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(folder / "post" / "particles_600.vtp"))
    reader.Update()
    poly = reader.GetOutput()
    assert poly.GetNumberOfPoints() == 60 and poly.GetNumberOfVerts() == 60
    data = poly.GetPointData()
    arrays = {data.GetArrayName(k): vtk_to_numpy(data.GetArray(k)) for k in range(data.GetNumberOfArrays())}
    assert set(arrays) == {"id", "type", "velocity", "force", "omega", "radius"}
    assert list(arrays["id"]) == list(range(1, 61)) and set(arrays["type"]) == {1}
    assert np.all((arrays["radius"] >= 0.002) & (arrays["radius"] <= 0.003))
    s = read_csv(folder / "series.csv")
    k = list(arrays["id"]).index(7)
    assert vtk_to_numpy(poly.GetPoints().GetData())[k, 0] == s["x[7]"][-1]
    assert arrays["velocity"][k, 2] == s["vz[7]"][-1] and arrays["omega"][k, 0] == s["omegax[7]"][-1]


def test_restart_continues_bitwise(engine_run):
    code, whole = engine_run(pouring_scene(steps=900), sub="whole")
    assert code == 0
    first = pouring_scene(steps=500) + [{"command": "create", "object": "restart", "file": "bed.restart"}]
    code, part = engine_run(first, sub="part")
    assert code == 0
    second = [material(), interaction(e=0.5, mu=0.3), model("hertz", "history"),
              {"command": "set", "property": "restart", "file": "../part/bed.restart"}] + gravity() + [
        {"command": "set", "property": "thermo", "every": 100, "columns": ["com_z", "contacts"]},
        {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": 300},
        {"command": "fix", "name": "dump"}, run(400)]
    code, cont = engine_run(second, sub="cont")
    assert code == 0
    assert filecmp.cmp(whole / "post/particles_900.vtp", cont / "post/particles_900.vtp", shallow=False)
    rows_whole = (whole / "thermo.csv").read_text().splitlines()
    rows_cont = (cont / "thermo.csv").read_text().splitlines()
    assert rows_cont[1:] == rows_whole[-len(rows_cont) + 1:]


def make_sim(commands):
    sim = Simulation(Log(None, echo=False))
    for k, cmd in enumerate(commands, start=1):
        sim.execute(cmd, k, "test.json")
    return sim


def two_in_contact(tangential, rolling="none"):
    return [domain(), material(), interaction(e=0.5, mu=0.3, rolling_friction=0.1),
            model("hertz", tangential, rolling=rolling), plane("floor", "z", -0.5),
            particle([0, 0, 0], velocity=[0, 0.1, 0]), particle([0.0199, 0, 0]), timestep(1e-5), run(10)]


def test_no_history_allocated_without_a_history_submodel(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the runs write thermo.csv
    sim = make_sim(two_in_contact("no_history"))
    assert overlaps(sim)[0] == 1  # the pair is in contact ...
    assert sim.nbr.hist.nbytes == 0 and sim.state.wall_hist.nbytes == 0  # ... and stores nothing
    sim = make_sim(two_in_contact("history"))
    assert sim.nbr.hist.shape == (len(sim.nbr.j), 3) and np.any(sim.nbr.hist != 0)
    assert sim.state.wall_hist.shape == (2, 1, 3)


def test_generated_kernel_holds_only_named_effects():
    base = generate_source(Combination(normal="hertz", tangential="none"))
    for absent in ("tangential_history(", "tangential_no_history(", "sjkr_", "rolling_", "nplanes",
                   "pair_hist[", "gravity[0]", "np.rint"):
        assert absent not in base
    full = generate_source(Combination(normal="hertz", tangential="history", cohesion="sjkr", rolling="epsd2",
                                       planes=True, cylinders=True, gravity=True, periodic=(True, False, False)))
    for present in ("tangential_history(", "sjkr_pair_force(", "sjkr_wall_force(", "rolling_epsd2(",
                    "plane_point[w, 0]", "cyl_radius[q]", "pair_hist[k, 3]", "gravity[0]", "dx -= box[0]"):
        assert present in full
    assert "dy -= box" not in full
    # walls: no mesh code without meshes, no bounds, extent, spin or rotation code unless a wall asks for it
    for absent in ("closest_point(", "mesh_rebuild(", "place_vertices(", "plane_lo[w", "cyl_lo[q]", "cyl_omega[q]",
                   "mesh_omega["):
        assert absent not in full
    still = generate_source(Combination(normal="hertz", tangential="history", meshes=True))
    for present in ("closest_point(", "edge_or_corner_counts(", "mesh_rebuild(", "take_coplanar_history("):
        assert present in still
    for absent in ("place_vertices(", "mesh_omega[", "nplanes = 0", "cyl_radius[q]"):
        assert absent not in still
    moving = generate_source(Combination(normal="hertz", tangential="none", meshes=True, mesh_motion=True))
    assert "shift_vertices(" in moving and "place_vertices(" not in moving and "take_coplanar_history(" not in moving
    assert "mesh_omega" not in moving.replace("mesh_omega = walls.mesh_omega", "")
    turning = generate_source(Combination(normal="hertz", meshes=True, mesh_motion=True, mesh_rotation=True,
                                          planes=True, bounded_planes=True, cylinders=True, cylinder_spin=True,
                                          cylinder_extent=True))
    for present in ("mesh_omega[mk]", "plane_lo[w, 0]", "cyl_lo[q]", "cyl_omega[q]"):
        assert present in turning


def test_timestep_above_critical_warns_and_fails_in_strict_mode(engine_run):
    scene = [domain(), material(), interaction(), model("hertz", "history"), particle([0, 0, 0]),
             timestep(2e-4)]  # Rayleigh time of these spheres is 8.65e-4 s: dt is 0.23 of it
    code, folder = engine_run(scene + [run(1)], sub="warn")
    assert code == 0
    assert "WARNING: time step 0.0002 s is 0.231 of the Rayleigh time" in (folder / "log.dem").read_text()
    strict = scene + [{"command": "set", "property": "timestep_check", "fraction": 0.2, "strict": True}, run(1)]
    code, folder = engine_run(strict, sub="strict")
    assert code == 1
    last = (folder / "log.dem").read_text().splitlines()[-1]
    assert last.startswith("ERROR: scene.json: command 8 (run): time step") and "strict" in last


def test_non_finite_values_stop_the_run_naming_step_and_particle(engine_run):
    scene = [domain(), material(), interaction(), model("hertz", "history"), particle([0, 0, 0]),
             particle([0.3, 0, 0]), particle([0.3, 0, 0]), timestep(1e-5)] + [
        {"command": "set", "property": "thermo", "every": 1}, run(5)]
    code, folder = engine_run(scene)
    assert code == 1
    log = (folder / "log.dem").read_text().splitlines()
    assert log[-1].startswith("ERROR: scene.json: command 10 (run): non-finite") and "at step 1" in log[-1]
    assert "particle 2 " in log[-1] or "particle 3 " in log[-1]
    assert read_csv(folder / "thermo.csv")["step"][0] == 0  # outputs so far stay readable
    timing = json.loads((folder / "timing.json").read_text())
    assert {"pair", "neigh", "comm", "modify", "output", "other", "total", "steps", "particles",
            "particle_steps_per_second"} <= set(timing)


def test_large_overlaps_are_warned_with_a_count(engine_run):
    scene = [domain(), material(), interaction(), model("hertz", "history"), particle([0, 0, 0]),
             particle([0.017, 0, 0]), timestep(1e-6), run(1)]
    code, folder = engine_run(scene)
    assert code == 0
    assert "WARNING: step 1: 1 contact(s) overlap more than 10% of the smaller radius" in \
        (folder / "log.dem").read_text()


def test_get_critical_timestep_matches_formulas(engine_run):
    scene = [domain(), material(y=1e7, nu=0.3, rho=2500), interaction(), model("hertz", "history"),
             particle([0, 0, 0], velocity=[1, 0, 0]), {"command": "get", "property": "critical_timestep"}]
    code, folder = engine_run(scene)
    assert code == 0
    line = [ln for ln in (folder / "log.dem").read_text().splitlines() if ln.startswith("critical_timestep:")][0]
    t_r = float(line.split("rayleigh_time = ")[1].split()[0])
    t_h = float(line.split("hertz_time = ")[1].split()[0])
    g = 1e7 / 2.6
    assert t_r == pytest.approx(math.pi * 0.01 * math.sqrt(2500 / g) / (0.1631 * 0.3 + 0.8766))
    m = 2500 * 4 / 3 * math.pi * 1e-6
    ystar = 1 / (2 * 0.91 / 1e7)
    assert t_h == pytest.approx(2.87 * (m * m / (0.005 * ystar ** 2 * 2.0)) ** 0.2)


def test_timestep_as_fraction_of_the_critical_one(engine_run):
    scene = [domain(), material(y=1e7, nu=0.3, rho=2500), interaction(), model("hertz", "none"),
             particle([0, 0, 0]), {"command": "set", "property": "timestep", "fraction_of_critical": 0.1},
             {"command": "set", "property": "thermo", "every": 1}, run(2)]
    code, folder = engine_run(scene)
    assert code == 0
    t_r = math.pi * 0.01 * math.sqrt(2500 / (1e7 / 2.6)) / (0.1631 * 0.3 + 0.8766)  # at rest: t_H infinite
    assert read_csv(folder / "thermo.csv")["time"][-1] == pytest.approx(2 * 0.1 * t_r, rel=1e-12)
    both = scene[:5] + [{"command": "set", "property": "timestep", "value": 1e-5, "fraction_of_critical": 0.1}]
    code, folder = engine_run(both, sub="both")
    assert code == 2 and "give either 'value' (s) or 'fraction_of_critical'" in (folder / "log.dem").read_text()
    early = [domain(), material(), interaction(), model("hertz", "none"),
             {"command": "set", "property": "timestep", "fraction_of_critical": 0.1}]
    code, folder = engine_run(early, sub="early")
    assert code == 2 and "needs particles" in (folder / "log.dem").read_text()
