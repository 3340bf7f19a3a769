"""The bundled engine never crashes and never passes broken physics silently.

Every case runs the real program (`python -m engine ...`) in a temporary folder and checks the contract of
engine/README.md: a failure is exactly one line `ERROR: ...` on stderr (and the last line of the log when
the log is writable), exit code 2 for bad input and 1 for a failed run, and never a Python traceback. The
physics cases check the guards' numbers (overlap ratio, step of a critical-time-step violation, lost count)
against values computed here from the formulas in /work/shared/physics.md.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]

# material of most scenes: Y = 1e7 Pa, nu = 0.3, rho = 2500 kg/m^3
Y, NU, RHO = 1e7, 0.3, 2500.0


def material(t=1, y=Y, nu=NU, rho=RHO):
    return {"command": "create", "object": "material", "type": t, "youngs_modulus": y, "poisson_ratio": nu,
            "density": rho}


def particle(position, radius=0.01, velocity=(0, 0, 0), t=1):
    return {"command": "create", "object": "particle", "type": t, "radius": radius, "position": list(position),
            "velocity": list(velocity)}


def base(lo=(-1, -1, -1), hi=(1, 1, 1), types=1):
    """Domain, `types` materials with all interactions, Hertz without tangential history (one cached kernel)."""
    cmds = [{"command": "create", "object": "domain", "lo": list(lo), "hi": list(hi)}]
    cmds += [material(t) for t in range(1, types + 1)]
    cmds += [{"command": "create", "object": "interaction", "types": [a, b], "restitution": 0.5}
             for a in range(1, types + 1) for b in range(a, types + 1)]
    cmds.append({"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "none"})
    return cmds


def timestep(dt):
    return {"command": "set", "property": "timestep", "value": dt}


def run(steps):
    return {"command": "run", "steps": steps}


def thermo(every, columns=(), file=None):
    cmd = {"command": "set", "property": "thermo", "every": every, "columns": list(columns)}
    if file is not None:
        cmd["file"] = file
    return cmd


GOOD = base() + [particle([0, 0, 0]), timestep(1e-5)]


def engine(folder: Path, script=None, *args, raw: bytes | None = None, log: str | None = "log.dem"):
    """Run `python -m engine -in scene.json [args] -log LOG` in folder; script is a command list or raw bytes."""
    folder.mkdir(parents=True, exist_ok=True)
    if raw is not None:
        (folder / "scene.json").write_bytes(raw)
    elif script is not None:
        (folder / "scene.json").write_text(json.dumps(script))
    argv = ["-in", "scene.json", *args] if (raw is not None or script is not None) else list(args)
    if log is not None:
        argv += ["-log", log]
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-m", "engine", *argv], cwd=folder, env=env, capture_output=True,
                          text=True, errors="replace", timeout=300)


def one_error(proc, code: int, *fragments: str, log: Path | None = None) -> str:
    """Asserts the failure contract and returns the ERROR line."""
    assert "Traceback" not in proc.stdout + proc.stderr, proc.stderr[-3000:]
    assert proc.returncode == code, (proc.returncode, proc.stderr[-3000:])
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ERROR: "), proc.stderr[-3000:]
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    if log is not None:
        assert log.read_text().splitlines()[-1] == lines[0]
    return lines[0]


def csv_text_is_finite(path: Path):
    """No inf or nan anywhere in a CSV file written by the engine (repr writes them as 'inf', 'nan')."""
    with open(path) as handle:
        for row in csv.reader(handle):
            for cell in row:
                assert cell.strip().lower() not in ("inf", "-inf", "nan"), (path, row)


# ---------------------------------------------------------------- the command line and the script file

@pytest.mark.parametrize("flag", ["-h", "--help"])
def test_help_prints_usage_and_exits_0(tmp_path, flag):
    proc = engine(tmp_path, None, flag, log=None)
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout.startswith("usage: ") and "-var NAME VALUE" in proc.stdout and "exit code" in proc.stdout


def test_non_utf8_script(tmp_path):
    raw = b'[{"command": "create", "object": "domain", "lo": [0, 0, 0], "hi": [1, 1, 1]}, "caf\xe9"]'
    one_error(engine(tmp_path, raw=raw), 2, "scene.json", "UTF-8", log=tmp_path / "log.dem")


def test_deeply_nested_json(tmp_path):
    one_error(engine(tmp_path, raw=b"[" * 100000), 2, "scene.json", "nest", log=tmp_path / "log.dem")


def test_nesting_the_parser_accepts_but_too_deep_for_a_field(tmp_path):
    """900 levels parse (CPython's limit is about 1000) but must not blow up substitution or echoing."""
    value = "[" * 900 + "1" + "]" * 900
    raw = ('[{"command": "create", "object": "domain", "lo": ' + value + ', "hi": [1, 1, 1]}]').encode()
    one_error(engine(tmp_path, raw=raw), 2, "scene.json", "nest", log=tmp_path / "log.dem")


def test_script_that_is_not_json(tmp_path):
    raw = b"atom_style granular\nregion box block 0 1 0 1 0 1\nrun 1000\n"
    one_error(engine(tmp_path, raw=raw), 2, "scene.json: not valid JSON", log=tmp_path / "log.dem")


def test_integer_literal_beyond_the_parser_digit_limit(tmp_path):
    raw = ('[{"command": "create", "object": "particle", "type": 1, "radius": ' + "7" * 5000 + "}]").encode()
    one_error(engine(tmp_path, raw=raw), 2, "scene.json", log=tmp_path / "log.dem")


def test_integer_too_large_for_a_double(tmp_path):
    script = GOOD[:-2] + [{"command": "create", "object": "particle", "type": 1, "radius": 10 ** 400,
                           "position": [0, 0, 0]}]
    one_error(engine(tmp_path, script), 2, "command 5 (create particle): field 'radius'", log=tmp_path / "log.dem")


# ---------------------------------------------------------------- log and output files

def test_log_in_a_missing_folder(tmp_path):
    one_error(engine(tmp_path, GOOD + [run(5)], log="/nonexistent/dir/log.txt"), 2, "/nonexistent/dir/log.txt",
              "No such file or directory")


def test_log_path_is_a_folder(tmp_path):
    (tmp_path / "logdir").mkdir()
    one_error(engine(tmp_path, GOOD + [run(5)], log="logdir"), 2, "logdir", "Is a directory")


def test_log_on_a_full_disk(tmp_path):
    """/dev/full accepts open() and fails every write with ENOSPC."""
    one_error(engine(tmp_path, GOOD + [run(5)], log="/dev/full"), 1, "/dev/full", "No space left on device")


@pytest.mark.parametrize("kind", ["thermo", "print", "restart_modifier", "restart_command", "timing"])
def test_outputs_on_a_full_disk(tmp_path, kind):
    # outputs stay inside the working folder (engine/README.md): a name there that is /dev/full
    (tmp_path / "full").symlink_to("/dev/full")
    script = GOOD + [thermo(5)]
    if kind == "thermo":
        script[-1]["file"] = "full"
    elif kind == "print":
        script += [{"command": "create", "object": "modifier", "name": "p", "kind": "print", "every": 5,
                    "file": "full", "quantities": ["ke"]}, {"command": "fix", "name": "p"}]
    elif kind == "restart_modifier":
        script += [{"command": "create", "object": "modifier", "name": "r", "kind": "restart", "every": 5,
                    "file": "full"}, {"command": "fix", "name": "r"}]
    elif kind == "restart_command":
        script += [{"command": "create", "object": "restart", "file": "full"}]
    if kind == "timing":
        (tmp_path / "timing.json").symlink_to("/dev/full")
    one_error(engine(tmp_path, script + [run(10)]), 1, "timing.json" if kind == "timing" else "full",
              "No space left on device", log=tmp_path / "log.dem")


def test_vtk_dump_into_an_unwritable_folder(tmp_path):
    """A dump folder nothing can be created in (/proc, even for root): one ERROR line, no VTK chatter."""
    (tmp_path / "proc").symlink_to("/proc")
    script = GOOD + [{"command": "create", "object": "modifier", "name": "d", "kind": "vtk", "every": 5,
                      "folder": "proc"}, {"command": "fix", "name": "d"}, run(10)]
    one_error(engine(tmp_path, script), 1, "proc", log=tmp_path / "log.dem")


def test_vtk_dump_folder_is_a_file(tmp_path):
    (tmp_path / "post").write_text("in the way\n")
    script = GOOD + [{"command": "create", "object": "modifier", "name": "d", "kind": "vtk", "every": 5},
                     {"command": "fix", "name": "d"}, run(10)]
    one_error(engine(tmp_path, script), 1, "post", log=tmp_path / "log.dem")


# ---------------------------------------------------------------- restart files

@pytest.fixture(scope="module")
def restart_file(tmp_path_factory) -> bytes:
    """A valid restart file of two particles (written by the engine itself, no run needed)."""
    folder = tmp_path_factory.mktemp("restart")
    proc = engine(folder, GOOD[:-2] + [particle([0, 0, 0]), particle([0.1, 0, 0]), timestep(1e-5),
                                         {"command": "create", "object": "restart", "file": "bed.restart"}])
    assert proc.returncode == 0, proc.stderr
    return (folder / "bed.restart").read_bytes()


def _tampered(restart: bytes, drop: str | None = None, **changes) -> bytes:
    """The restart file with arrays replaced or one dropped: what a broken or foreign writer could produce."""
    data = dict(np.load(io.BytesIO(restart), allow_pickle=False))
    data.update(changes)
    data.pop(drop, None)
    out = io.BytesIO()
    np.savez(out, **data)
    return out.getvalue()


CORRUPT = {
    "truncated": lambda good: good[:len(good) // 2],
    "garbage": lambda good: bytes(np.random.default_rng(7).integers(0, 256, 4000, dtype=np.uint8)),
    "text": lambda good: b'{"format": 2, "x": [[0, 0, 0]]}\n',
    "empty": lambda good: b"",
    "format_99": lambda good: _tampered(good, format=np.array(99)),
    "missing_array": lambda good: _tampered(good, drop="radius"),
    # arrays of different lengths would make the compiled kernel (no bounds checks) read past an array
    "radius_short": lambda good: _tampered(good, radius=np.array([0.01])),
    "neighbor_out_of_range": lambda good: _tampered(good, nbr_start=np.array([0, 1, 1]), nbr_j=np.array(
        [5000], dtype=np.int32), pair_hist=np.zeros((1, 0))),
    "nan_position": lambda good: _tampered(good, x=np.array([[0.0, 0, 0], [np.nan, 0, 0]])),
    "walls_not_json": lambda good: _tampered(good, walls=np.array("[{")),
}


@pytest.mark.parametrize("case", sorted(CORRUPT))
def test_corrupt_restart_file(tmp_path, restart_file, case):
    (tmp_path / "bed.restart").write_bytes(CORRUPT[case](restart_file))
    script = base() + [{"command": "set", "property": "restart", "file": "bed.restart"}, run(5)]
    one_error(engine(tmp_path, script), 2, "command 5 (set restart): field 'file'", "bed.restart",
              log=tmp_path / "log.dem")


def test_valid_restart_still_reads(tmp_path, restart_file):
    (tmp_path / "bed.restart").write_bytes(restart_file)
    script = base() + [{"command": "set", "property": "restart", "file": "bed.restart"}, run(5)]
    proc = engine(tmp_path, script)
    assert proc.returncode == 0, proc.stderr
    assert "read restart file bed.restart: step 0, 2 particles" in proc.stdout


# ---------------------------------------------------------------- memory

def test_lattice_that_cannot_fit_in_memory(tmp_path):
    """1 m^3 at 0.1 mm spacing: 1e12 sites, hundreds of TB before a single particle is stored."""
    script = base() + [{"command": "create", "object": "lattice", "type": 1, "radius": 4e-5, "spacing": 1e-4,
                        "region": {"shape": "box", "lo": [-0.5, -0.5, -0.5], "hi": [0.5, 0.5, 0.5]}}]
    line = one_error(engine(tmp_path, script), 2, "command 5 (create lattice): field 'spacing'", "memory",
                     log=tmp_path / "log.dem")
    assert "1e+12" in line


def test_random_packing_that_cannot_fit_in_memory(tmp_path):
    script = base() + [{"command": "create", "object": "random_packing", "type": 1, "count": 10 ** 12, "seed": 1,
                        "radius": 1e-6, "region": {"shape": "box", "lo": [-1, -1, -1], "hi": [1, 1, 1]}}]
    one_error(engine(tmp_path, script), 2, "command 5 (create random_packing): field 'count'", "memory",
              log=tmp_path / "log.dem")


# ---------------------------------------------------------------- extreme values

EXTREME = {
    # name: (script, variables, exit code, fragments of the ERROR line)
    "velocity 1e200": (base() + [particle([0, 0, 0], velocity=[1e200, 0, 0]), timestep(1e-5), thermo(1), run(5)],
                       {}, 2, ["command 5 (create particle): field 'velocity'"]),
    "density 1e-300": (base()[:1] + [material(rho=1e-300)] + base()[2:] + [particle([0, 0, 0]), timestep(1e-5),
                                                                            thermo(1), run(5)],
                       {}, 2, ["command 5 (create particle)", "density"]),
    "radius 1e-200": (base() + [particle([0, 0, 0], radius=1e-200), timestep(1e-5), run(5)],
                      {}, 2, ["command 5 (create particle): field 'radius'"]),
    "radius 0": (base() + [particle([0, 0, 0], radius="${R}"), timestep(1e-5), run(5)], {"R": "0"}, 2,
                 ["field 'radius' must be > 0"]),
    "radius negative": (base() + [particle([0, 0, 0], radius="${R}"), timestep(1e-5), run(5)], {"R": "-0.01"}, 2,
                        ["field 'radius' must be > 0"]),
    "radius nan": (base() + [particle([0, 0, 0], radius="${R}"), timestep(1e-5), run(5)], {"R": "nan"}, 2,
                   ["field 'radius' must be a number"]),
    "velocity inf": (base() + [particle([0, 0, 0], velocity=["${V}", 0, 0]), timestep(1e-5), run(5)],
                     {"V": "inf"}, 2, ["field 'velocity' must be a list of 3 numbers"]),
    "timestep -inf": (base() + [particle([0, 0, 0]), timestep("${DT}"), run(5)], {"DT": "-inf"}, 2,
                      ["field 'value' must be a number"]),
    "steps nan": (GOOD + [run("${STEPS}")], {"STEPS": "nan"}, 2, ["field 'steps' must be an integer"]),
    "steps 1e30": (GOOD + [run("${STEPS}")], {"STEPS": "1e30"}, 2, ["field 'steps' must be <="]),
    "lattice spacing 1e-320": (base() + [{"command": "create", "object": "lattice", "type": 1, "radius": 1e-321,
                                          "spacing": 1e-320, "region": {"shape": "box", "lo": [0, 0, 0],
                                                                        "hi": [1, 1, 1]}}],
                               {}, 2, ["command 5 (create lattice): field 'spacing'"]),
    # the pair parameter table, built at run start, would hold 1e18 rows
    "material type 1e9": (base() + [material(t=10 ** 9), particle([0, 0, 0]), timestep(1e-5), run(1)], {}, 2,
                          ["command 5 (create material): field 'type'"]),
    "domain wider than a double": (base(lo=(-1e308, -1, -1), hi=(1e308, 1, 1)) + [particle([0, 0, 0]),
                                                                               timestep(1e-5), run(5)],
                                   {}, 2, ["command 1 (create domain)"]),
    # v = 5e294 m/s after one step: finite, but its kinetic energy 0.5 m v^2 overflows (the tall domain keeps
    # the particle inside, so it is not simply removed as lost)
    "gravity 1e300 blows up": (base(lo=(-1, -1, -1e300)) + [
        particle([0, 0, 0]), timestep(1e-5),
        {"command": "create", "object": "modifier", "name": "g", "kind": "gravity", "acceleration": [0, 0, "${G}"]},
        {"command": "fix", "name": "g"}, thermo(1, ["max_speed", "energy"]), run(400)],
        {"G": "-1e300"}, 1, ["command 10 (run)", "non-finite", "particle 1", "at step 1"]),
}


@pytest.mark.parametrize("case", sorted(EXTREME))
def test_extreme_values(tmp_path, case):
    script, variables, code, fragments = EXTREME[case]
    args = [a for name, value in variables.items() for a in ("-var", name, value)]
    one_error(engine(tmp_path, script, *args), code, *fragments, log=tmp_path / "log.dem")
    if (tmp_path / "thermo.csv").exists():
        csv_text_is_finite(tmp_path / "thermo.csv")


# ---------------------------------------------------------------- physics guards

def test_overlap_at_step_0_is_warned_with_count_and_ratio(tmp_path):
    """Spheres of 10 mm and 5 mm with centres 6 mm apart overlap by 9 mm = 180 % of the smaller radius."""
    script = base() + [particle([0, 0, 0], radius=0.01), particle([0.006, 0, 0], radius=0.005),
                       particle([0.5, 0.5, 0.5]), timestep(1e-7), run(0)]
    proc = engine(tmp_path, script)
    assert proc.returncode == 0, proc.stderr
    warnings = [ln for ln in (tmp_path / "log.dem").read_text().splitlines() if "overlap more than" in ln]
    assert len(warnings) == 1, warnings
    assert warnings[0].startswith("WARNING: step 0") and "1 contact(s)" in warnings[0]
    assert "(max 180.0%)" in warnings[0], warnings[0]


def test_overlap_with_a_wall_at_step_0_is_warned(tmp_path):
    """A sphere of radius 10 mm whose centre sits 4 mm above the floor overlaps it by 6 mm = 60 %."""
    floor = {"command": "create", "object": "wall", "name": "floor", "shape": "plane", "axis": "z",
             "position": 0.0, "type": 1}
    script = base() + [floor, particle([0, 0, 0.004]), particle([0.5, 0.5, 0.5]), timestep(1e-7), run(0)]
    proc = engine(tmp_path, script)
    assert proc.returncode == 0, proc.stderr
    warnings = [ln for ln in (tmp_path / "log.dem").read_text().splitlines() if "overlap" in ln
                and ln.startswith("WARNING")]
    assert len(warnings) == 1 and "1 particle-wall contact(s)" in warnings[0] and "(max 60.0%)" in warnings[0], \
        warnings


def hertz_time(v_rel, r=0.01, rho=RHO, y_star=Y / (2 * (1 - NU ** 2))):
    """Hertz time 2.87 (m^2 / (R Y*^2 v))^(1/5), m = particle mass, R = r/2 (LIGGGHTS check/timestep/gran)."""
    m = rho * 4.0 / 3.0 * math.pi * r ** 3
    return 2.87 * (m * m / (0.5 * r * y_star ** 2 * v_rel)) ** 0.2


# A sphere falls from rest under g = 900 m/s^2 at dt = 1.6e-4 s (0.185 of its Rayleigh time, so the check at
# run start passes: v = 0 gives an infinite Hertz time). Its relative speed 2 g t crosses the speed at which
# dt = 0.2 t_H during the run; the engine re-checks every 1000 steps.
FALL_G, FALL_DT, FALL_STEPS = 900.0, 1.6e-4, 3500


def falling_scene(strict: bool):
    return base(lo=(-1, -1, -400), hi=(1, 1, 1)) + [
        particle([0, 0, 0]), timestep(FALL_DT),
        {"command": "set", "property": "timestep_check", "fraction": 0.2, "strict": strict},
        {"command": "create", "object": "modifier", "name": "g", "kind": "gravity",
         "acceleration": [0, 0, -FALL_G]}, {"command": "fix", "name": "g"}, run(FALL_STEPS)]


def first_violation_step(every=1000):
    """First multiple of `every` at which dt > 0.2 t_H(2 v), v = g t (velocity Verlet is exact for free fall)."""
    for step in range(every, FALL_STEPS + 1, every):
        if FALL_DT > 0.2 * hertz_time(2 * FALL_G * step * FALL_DT):
            return step
    return None


def test_critical_timestep_is_rechecked_during_the_run(tmp_path):
    expected = first_violation_step()
    assert expected == 2000  # the scene is built so that the check at step 1000 passes and 2000 fails
    proc = engine(tmp_path, falling_scene(strict=False))
    assert proc.returncode == 0, proc.stderr
    log = (tmp_path / "log.dem").read_text().splitlines()
    hertz = [ln for ln in log if ln.startswith("WARNING") and "Hertz time" in ln]
    assert len(hertz) == 1, hertz  # warned once per run, at the first step it is exceeded
    assert hertz[0].startswith(f"WARNING: step {expected}: "), hertz[0]
    t_h = hertz_time(2 * FALL_G * expected * FALL_DT)
    assert f"{FALL_DT / t_h:.3g} of the Hertz time {t_h:.4g} s" in hertz[0], (hertz[0], t_h)


def test_critical_timestep_recheck_is_an_error_in_strict_mode(tmp_path):
    proc = engine(tmp_path, falling_scene(strict=True))
    one_error(proc, 1, f"step {first_violation_step()}", "Hertz time", "strict", log=tmp_path / "log.dem")


def test_hertz_time_with_several_types_uses_the_stiffest_partner(tmp_path):
    """Documented choice (engine/README.md): t_H of a particle uses the largest Y* over every type it can
    touch (particles and walls) and the whole wall speed, not LIGGGHTS' own-type Y* only."""
    script = base(types=2)
    script[2] = material(2, y=1e9)  # type 2 is 100 times stiffer
    wall = {"command": "create", "object": "wall", "name": "floor", "shape": "plane", "axis": "z",
            "position": -0.5, "type": 2, "velocity": [3.0, 0, 0]}
    script += [wall, particle([0, 0, 0], velocity=[1, 0, 0]), {"command": "get", "property": "critical_timestep"}]
    proc = engine(tmp_path, script)
    assert proc.returncode == 0, proc.stderr
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("critical_timestep:")][0]
    t_h = float(line.split("hertz_time = ")[1].split()[0])
    y_star = 1.0 / ((1 - NU ** 2) / Y + (1 - NU ** 2) / 1e9)  # type 1 against type 2
    assert t_h == pytest.approx(hertz_time(max(2 * 1.0, 1.0 + 3.0), y_star=y_star), rel=1e-12)
    own_type_only = hertz_time(2 * 1.0)  # LIGGGHTS 3.8: own type pair, primitive walls ignored
    assert t_h < 0.7 * own_type_only  # (Y* ratio 1.98)^-0.4 (speed ratio 2)^-0.2 = 0.66


def drifting_scene(velocities):
    """Spheres 10 mm apart along y moving along +x at the given speeds in a 0.2 m box, 50 steps of 1 ms."""
    return base(lo=(-0.1, -0.1, -0.1), hi=(0.1, 0.1, 0.1)) + [
        particle([0, 0.02 * k - 0.04, 0], radius=0.004, velocity=[v, 0, 0]) for k, v in enumerate(velocities)
    ] + [timestep(1e-3), thermo(10), run(50)]


def test_some_particles_lost_are_warned_and_counted(tmp_path):
    """At 3 m/s a sphere leaves the +x face (0.1 m) within 34 steps; at 1 m/s it stays in 50 steps."""
    proc = engine(tmp_path, drifting_scene([3.0, 1.0, 3.0, 1.0]))
    assert proc.returncode == 0, proc.stderr
    log = (tmp_path / "log.dem").read_text().splitlines()
    lost = [ln for ln in log if ln.startswith("WARNING") and "left the fixed domain" in ln]
    assert lost and sum(int(ln.split("WARNING: ")[1].split()[0]) for ln in lost) == 2, lost
    assert log[-1].startswith("total: 50 steps, 2 particles, 2 lost"), log[-1]


def test_every_particle_lost_is_an_error(tmp_path):
    proc = engine(tmp_path, drifting_scene([3.0, 3.0]))
    line = one_error(proc, 1, "command 9 (run)", "all 2 particles", log=tmp_path / "log.dem")
    assert "step 34" in line, line  # x = 0.1 is crossed after 0.1 / 3 s = 33.3 ms
