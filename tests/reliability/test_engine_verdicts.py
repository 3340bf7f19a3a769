"""The bundled engine refuses what it cannot simulate (exit 2, one line naming the field), never writes a NaN
into a successful run's output, writes only inside its working folder, and stops a run that has clearly
blown up (exit 1) by the rule of engine/blowup.py - while a sound run at the default time step passes.

Every case runs the real program (`python -m engine`), as tests/reliability/test_engine_faults.py does.
"""
from __future__ import annotations

import csv
import struct

import numpy as np
import pytest

from test_engine_faults import GOOD, base, engine, one_error, particle, run, thermo, timestep


def triangles_bytes(count: int) -> bytes:
    """``count`` triangles of a flat strip, in binary STL records (normal, 3 vertices, attribute)."""
    out = b""
    for k in range(count):
        vertices = [(k, 0, 0), (k + 1, 0, 0), (k, 1, 0)]
        out += struct.pack("<12fH", 0, 0, 1, *[c * 0.01 for v in vertices for c in v], 0)
    return out


def binary_stl(declared: int, records: bytes) -> bytes:
    return b"binary strip".ljust(80, b" ") + struct.pack("<I", declared) + records


def mesh_scene(file="m.stl", **extra):
    wall = {"command": "create", "object": "wall", "name": "m", "shape": "mesh", "type": 1, "file": file, **extra}
    return base() + [wall, particle([0.0, 0.0, 0.5]), timestep(1e-5), run(10)]


@pytest.mark.parametrize("case", ["count_larger", "cut_in_a_triangle", "ascii_cut"])
def test_a_damaged_stl_file_is_refused(tmp_path, case):
    if case == "count_larger":
        data = binary_stl(6, triangles_bytes(4))
    elif case == "cut_in_a_triangle":
        data = binary_stl(4, triangles_bytes(4))[:-20]
    else:
        facet = ("facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n endloop\n"
                 "endfacet\n")
        data = ("solid strip\n" + facet * 3 + facet[:40]).encode()
    (tmp_path / "m.stl").write_bytes(data)
    line = one_error(engine(tmp_path, mesh_scene()), 2, "field 'file'", "m.stl")
    assert "truncated" in line or "cut short" in line
    # the whole file still loads
    (tmp_path / "m.stl").write_bytes(binary_stl(4, triangles_bytes(4)))
    assert engine(tmp_path, mesh_scene()).returncode == 0


def test_column_of_a_particle_that_never_existed_is_refused_before_the_run(tmp_path):
    one_error(engine(tmp_path, GOOD + [thermo(5, ["z[99]"]), run(10)]), 2, "field 'steps'", "z[99]",
              "particle 99", "does not exist")
    assert not (tmp_path / "thermo.csv").exists()


@pytest.mark.parametrize("column", ["z[1]", "com_x"])
def test_columns_of_a_scene_without_particles_are_refused(tmp_path, column):
    one_error(engine(tmp_path, base() + [timestep(1e-5), thermo(5, [column]), run(10)]), 2, column)


def test_a_removed_particles_column_stops_the_run_naming_particle_and_step(tmp_path):
    # particle 1 flies out of the fixed domain (removed at a neighbor rebuild), particle 2 stays
    script = base(lo=(-0.1, -0.1, -0.1), hi=(0.1, 0.1, 0.1)) + [
        particle([0.08, 0, 0], velocity=(10.0, 0, 0)), particle([-0.05, 0, 0]), timestep(1e-5),
        thermo(20, ["x[1]", "x[2]"]), run(2000)]
    line = one_error(engine(tmp_path, script), 1, "column 'x[1]'", "particle 1 is not present at step")
    step = int(line.split("at step ")[1].split()[0])
    assert 20 <= step <= 2000
    with open(tmp_path / "thermo.csv") as handle:
        rows = list(csv.reader(handle))
    assert all(cell.lower() not in ("nan", "inf", "-inf") for row in rows for cell in row)


@pytest.mark.parametrize("case", ["youngs_modulus", "mesh_velocity", "steps", "timestep"])
def test_values_beyond_what_can_be_simulated_are_bad_input(tmp_path, case):
    if case == "youngs_modulus":
        script = [c if c.get("object") != "material" else {**c, "youngs_modulus": 1e300} for c in GOOD]
        one_error(engine(tmp_path, script + [run(10)]), 2, "field 'youngs_modulus'")
    elif case == "mesh_velocity":
        (tmp_path / "m.stl").write_bytes(binary_stl(4, triangles_bytes(4)))
        one_error(engine(tmp_path, mesh_scene(velocity=[1e200, 0, 0])), 2, "wall 'm'", "velocity")
    elif case == "steps":
        one_error(engine(tmp_path, GOOD + [{"command": "run", "steps": "${2**100000}"}]), 2, "2**100000",
                  "beyond double precision")
    else:
        one_error(engine(tmp_path, base() + [particle([0, 0, 0]), timestep(5e-324), run(10)]), 2,
                  "field 'value'", "resolve")


@pytest.mark.parametrize("field", ["vtk_folder", "vtk_prefix", "thermo_file", "print_file", "restart_file"])
def test_output_paths_never_leave_the_working_folder(tmp_path, field):
    work = tmp_path / "a" / "b"
    script = list(GOOD)
    if field.startswith("vtk"):
        key, value = ("folder", "../../x") if field == "vtk_folder" else ("prefix", "../../../x/p")
        script += [{"command": "create", "object": "modifier", "name": "d", "kind": "vtk", "every": 5, key: value},
                   {"command": "fix", "name": "d"}]
    elif field == "thermo_file":
        script.append(thermo(5, file=str(tmp_path / "x.csv")))
    elif field == "print_file":
        script += [{"command": "create", "object": "modifier", "name": "p", "kind": "print", "every": 5,
                    "file": "../../x.csv", "quantities": ["ke"]}, {"command": "fix", "name": "p"}]
    else:
        script.append({"command": "create", "object": "restart", "file": "../x.npz"})
    one_error(engine(work, script + [run(10)]), 2, "leaves the working folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["b"]


# ---------------------------------------------------------------- blow-up

def gas(fraction: float, steps: int = 300, blowup: dict | None = None) -> list:
    """500 spheres (r = 4 mm, Y = 1e7 Pa) on a lattice in a periodic box, random velocities (sd 1 m/s),
    Hertz with history, at ``fraction`` of the critical time step."""
    rng = np.random.default_rng(1)
    cmds = [{"command": "create", "object": "domain", "lo": [0, 0, 0], "hi": [0.1, 0.1, 0.1],
             "periodic": [True, True, True]},
            {"command": "create", "object": "material", "type": 1, "youngs_modulus": 1e7, "poisson_ratio": 0.3,
             "density": 2500},
            {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.9},
            {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"}]
    sites = [(i, j, k) for i in range(8) for j in range(8) for k in range(8)][:500]
    cmds += [particle([0.00625 + 0.0125 * i, 0.00625 + 0.0125 * j, 0.00625 + 0.0125 * k], radius=0.004,
                      velocity=rng.normal(0, 1.0, 3).tolist()) for i, j, k in sites]
    cmds += [{"command": "set", "property": "timestep", "fraction_of_critical": fraction},
             thermo(50, ["max_overlap", "max_speed"])]
    if blowup is not None:
        cmds.append({"command": "set", "property": "blowup", **blowup})
    return cmds + [run(steps)]


@pytest.mark.parametrize("fraction", [1.5, 5.0])
def test_a_blown_up_gas_fails_by_default(tmp_path, fraction):
    # the default overlap limit: overlaps beyond the radius within 100 steps
    line = one_error(engine(tmp_path, gas(fraction)), 1, "blow-up at step ",
                     "of the smaller radius, above the limit 50%")
    assert int(line.split("blow-up at step ")[1].split(":")[0]) <= 100, line
    assert float(line.split("overlaps ")[1].split("%")[0]) > 100.0
    # the time-step limit a scene may ask for stops it before the first step
    one_error(engine(tmp_path / "dt", gas(fraction, blowup={"timestep_factor": 1})), 1, "blow-up at step 0",
              "times the critical")


def test_the_same_gas_at_the_default_time_step_passes_and_a_declared_hard_case_runs(tmp_path):
    ok = engine(tmp_path, gas(0.2))
    assert ok.returncode == 0, ok.stderr
    with open(tmp_path / "thermo.csv") as handle:
        overlaps = [float(row["max_overlap"]) for row in csv.DictReader(handle)]
    assert 0.1 < max(overlaps) < 0.5  # a soft gas overlaps, well below the limit
    relaxed = engine(tmp_path / "hard", gas(1.5, steps=100, blowup={"enabled": False}))
    assert relaxed.returncode == 0, relaxed.stderr
