"""The program contract: bad input gives one ERROR line naming command and field, exit code 2."""
import json
import os
import shutil
import subprocess
import sys

import pytest

from conftest import REPO, domain, interaction, material, model, particle, read_csv, run, timestep

GOOD = [domain(), material(), interaction(), model("hertz", "history"), particle([0, 0, 0]), timestep(1e-5)]


def replace(index, **fields):
    """GOOD with command `index` (0-based) changed; a field set to None is removed."""
    script = [dict(c) for c in GOOD]
    for key, value in fields.items():
        if value is None:
            script[index].pop(key)
        else:
            script[index][key] = value
    return script


BAD_INPUT = {
    "unknown command": (GOOD + [{"command": "explode"}], "command 7: unknown command \"explode\""),
    "missing field": (replace(4, radius=None), "command 5 (create particle): field 'radius' is missing"),
    "mistyped field": (replace(4, radius="big"), "command 5 (create particle): field 'radius' must be a number"),
    "unknown material": (replace(4, type=3), "command 5 (create particle): field 'type' names unknown material type 3"),
    "negative radius": (replace(4, radius=-0.01), "command 5 (create particle): field 'radius' must be > 0"),
    "zero time step": (replace(5, value=0), "command 6 (set timestep): field 'value' must be > 0"),
    "restitution above 1": (replace(2, restitution=1.5),
                            "command 3 (create interaction): field 'restitution' must be in (0, 1]"),
    "restitution zero": (replace(2, restitution=0), "command 3 (create interaction): field 'restitution' must be in"),
    "poisson above 0.5": (replace(1, poisson_ratio=0.6),
                          "command 2 (create material): field 'poisson_ratio' must be <= 0.5"),
    "variable without value": (replace(4, radius="${R}"), "command 5 (create): variable '${R}' has no value"),
    "unknown field": (replace(4, colour="red"), "command 5 (create particle): field 'colour' is not a field"),
    "unknown model": (replace(3, normal="jkr"), "command 4 (create contact_model): field 'normal' must be one of"),
    "unknown wall in thermo": (GOOD + [{"command": "set", "property": "thermo", "columns": ["wall_fz[floor]"]}],
                               "command 8 (run): field 'steps' cannot run: quantity 'wall_fz[floor]' names no wall"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUT))
def test_bad_input_is_one_line_with_exit_code_2(engine_run, capsys, case):
    script, expected = BAD_INPUT[case]
    code, folder = engine_run(script + [run(10)])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ERROR: scene.json: ") and expected in err[0], err
    assert (folder / "log.dem").read_text().splitlines()[-1] == err[0]


def test_outputs_before_a_bad_command_stay_valid(engine_run):
    script = GOOD + [{"command": "set", "property": "thermo", "every": 10}, run(50),
                     {"command": "create", "object": "particle", "type": 1, "radius": -1, "position": [0, 0, 0.5]}]
    code, folder = engine_run(script)
    assert code == 2
    thermo = read_csv(folder / "thermo.csv")
    assert list(thermo["step"]) == [0, 10, 20, 30, 40, 50]
    timing = json.loads((folder / "timing.json").read_text())
    assert timing["steps"] == 50 and timing["particles"] == 1


def test_unreadable_and_invalid_scripts(engine_run, tmp_path, capsys):
    from engine.__main__ import run as run_engine

    os.chdir(tmp_path)
    assert run_engine("missing.json", "log.dem", {}, echo=False) == 2
    assert "ERROR: missing.json: cannot read input script" in capsys.readouterr().err
    (tmp_path / "broken.json").write_text('[{"command": "create",]')
    assert run_engine("broken.json", "log.dem", {}, echo=False) == 2
    assert "ERROR: broken.json: not valid JSON" in capsys.readouterr().err


def test_variables_fill_numbers_and_strings(engine_run):
    script = replace(4, radius="${R}") + [
        {"command": "create", "object": "modifier", "name": "p", "kind": "print", "every": 5,
         "file": "out_${NAME}.csv", "quantities": ["x[1]"]}, {"command": "fix", "name": "p"}, run(5)]
    code, folder = engine_run(script, variables={"R": "0.02", "NAME": "abc"})
    assert code == 0
    assert (folder / "out_abc.csv").exists()


def test_program_runs_with_only_engine_on_the_path(tmp_path):
    """Like the harness: engine/ exported alone into a build folder, run as `python -m engine` from a run folder."""
    build = tmp_path / "build" / "src"
    shutil.copytree(REPO / "engine", build / "engine", ignore=shutil.ignore_patterns("__pycache__"))
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "scene.json").write_text(json.dumps(GOOD + [run(20)]))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(build)
    proc = subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json", "-log", "log.txt"], cwd=folder,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (folder / "log.txt").exists() and (folder / "thermo.csv").exists()
    assert read_csv(folder / "thermo.csv")["step"][-1] == 20
    timing = json.loads((folder / "timing.json").read_text())
    assert timing["steps"] == 20 and timing["comm"] == 0.0
    # bad input through the real program: exit 2 and exactly one stderr line
    proc = subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json", "-var"], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert proc.stderr.startswith("ERROR: bad command line argument")


def test_second_run_loads_the_kernel_from_the_disk_cache(tmp_path):
    """The generated kernel and its machine code land in $DEM_CACHE_DIR; a new process does not compile again,
    even from another build of the engine (a new folder) whose commit changed docstrings, comments and a
    module without compiled code: the machine code is keyed by content (engine/jit.py), not by files."""
    cache = tmp_path / "cache"
    scene = [domain(), material(), interaction(), model("hooke", "none", characteristic_velocity=1.0),
             particle([0, 0, 0]), timestep(1e-5), run(5)]
    build = tmp_path / "build" / "engine"
    shutil.copytree(REPO / "engine", build, ignore=shutil.ignore_patterns("__pycache__"))
    edits = {"neighbor.py": ('"""Rebuild the neighbor list', '"""Rebuilds the neighbor list'),
             "kernels.py": ('"""Kernel builder:', '"""The kernel builder:'),
             "contact_laws.py": ("    sqrt_rd = sqrt(reff * overlap)\n", "    sqrt_rd = sqrt(reff * overlap)  # m\n"),
             "commands.py": ('"""', '"""Changed. ')}
    for name, (old, new) in edits.items():
        text = (build / name).read_text()
        assert old in text, name
        (build / name).write_text(text.replace(old, new, 1))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(DEM_CACHE_DIR=str(cache))
    compile_seconds, machine_code = [], []
    for attempt, source in (("first", REPO), ("second", build.parent)):
        folder = tmp_path / attempt
        folder.mkdir()
        (folder / "scene.json").write_text(json.dumps(scene))
        proc = subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json"], cwd=folder,
                              env=dict(env, PYTHONPATH=str(source)), capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        compile_seconds.append(json.loads((folder / "timing.json").read_text())["compile"])
        machine_code.append(sorted(p.name for p in cache.rglob("*.nbc")))
    kernels = list(cache.glob("dem_kernel_*.py"))
    assert len(kernels) == 1 and "hooke_normal" in kernels[0].read_text()
    assert "tangential" not in kernels[0].read_text().split('"""', 2)[2]  # only the named laws
    assert list((cache / "jit").glob("run_steps-*.nbi"))  # named by the function and its content key
    assert machine_code[1] == machine_code[0]  # nothing compiled anew
    assert compile_seconds[1] < 0.25 * compile_seconds[0], compile_seconds
