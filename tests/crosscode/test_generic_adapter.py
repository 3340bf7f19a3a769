"""The generic adapter (a JSON file instead of Python) and adapters from other packages (entry points).

The generic adapter is exercised on a real DEM code: LAMMPS described by a JSON file (thermo from log lines
with a regular expression), against the LAMMPS adapter on the same scene.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from crosscode_testing import PROJECT, harness, needs_lammps, records, series
from harness.adapters import get_adapter
from harness.adapters.base import UserError
from harness.adapters.generic import GenericAdapter

LAMMPS_AS_GENERIC = {
    "description": "LAMMPS described without Python",
    "command": ["{executable}", "-in", "{script}", "{variables}", "-log", "{log}"],
    "variable": ["-var", "{name}", "{value}"],
    "log": "log.lammps",
    "scripts": ["in.*"],
    "thermo": {"log_pattern": r"^\s*(?P<Step>\d+)\s+(?P<Atoms>\d+)\s+(?P<KinEng>\S+)\s+(?P<c_rke>\S+)\s*$",
               "columns": {"step": "Step", "atoms": "Atoms", "ke": "KinEng", "rke": "c_rke"}},
    "timing": {"total": r"^Loop time of (\S+) on", "pair": r"^Pair\s+\|[^|]*\|\s*(\S+)"},
    "errors": ["^ERROR"],
}


def test_command_template(tmp_path):
    path = tmp_path / "code.json"
    path.write_text(json.dumps(LAMMPS_AS_GENERIC))
    adapter = get_adapter(f"generic:{path}")
    assert isinstance(adapter, GenericAdapter) and adapter.name == f"generic:{path}"
    assert adapter.command(["/usr/bin/lmp"], "in.x", {"a": 1, "b": "two"}, "log.lammps",
                           ["mpirun", "-np", "2"]) == [
        "mpirun", "-np", "2", "/usr/bin/lmp", "-in", "in.x", "-var", "a", "1", "-var", "b", "two",
        "-log", "log.lammps"]
    assert adapter.log_file() == "log.lammps"
    assert adapter.accepts_script("in.scene") and not adapter.accepts_script("scene.json")


def test_file_problems_are_one_line_each(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text(json.dumps({"command": ["{executable}"], "thermo": {"csv": "t.csv", "log_pattern": "(x"},
                                "timing": {"pair": "no group", "wall": "(\\S+)"}, "vtk": "post/*.vtp"}))
    with pytest.raises(UserError) as failure:
        get_adapter(f"generic:{path}")
    message = str(failure.value)
    for part in ("$.command: must contain {script}", "$.thermo: needs exactly one of csv and log_pattern",
                 "$.thermo.log_pattern: not a regular expression", "$.timing.pair: needs a group holding the seconds",
                 "$.timing.wall: unknown timing key", "$.vtk: must be a list of glob patterns, got string"):
        assert f"{path}: {part}" in message, message
    with pytest.raises(UserError, match=r"missing\.json: generic adapter file not found"):
        get_adapter(f"generic:{tmp_path / 'missing.json'}")
    with pytest.raises(UserError, match=r"unknown engine adapter 'generic'.*generic:FILE"):
        get_adapter("generic")


def test_csv_thermo_and_patterns(tmp_path):
    config = {"command": ["{executable}", "{script}"], "log": "run.log",
              "thermo": {"csv": "out/energy.csv", "delimiter": "whitespace",
                         "columns": {"step": "it", "atoms": "n", "ke": "Et", "rke": "Er"}},
              "timing": {"total": r"^took (\S+) s"}, "errors": ["^Fatal"], "warnings": ["^Careful"],
              "vtk": ["out/*.vtp"]}
    path = tmp_path / "code.json"
    path.write_text(json.dumps(config))
    adapter = get_adapter(f"generic:{path}")
    run = tmp_path / "run"
    (run / "out").mkdir(parents=True)
    (run / "out" / "energy.csv").write_text("it n Et Er extra\n0 4 1.5 0.0 7\n10 4 1.25 0.125 8\n")
    (run / "run.log").write_text("Careful: dt large\ntook 0.5 s\ntook 0.25 s\n")
    (run / "stderr.txt").write_text("Fatal: out of particles\n")
    for step in (20, 0, 10):
        (run / "out" / f"p_{step}.vtp").write_text("")
    thermo = adapter.read_thermo(run)
    assert list(thermo.columns) == ["step", "atoms", "ke", "rke", "extra"]
    assert list(thermo["ke"]) == [1.5, 1.25] and thermo["step"].dtype.kind == "i"
    assert adapter.read_timing(run)["total"] == 0.75
    scan = adapter.scan_log(run)
    assert scan.errors == ["Fatal: out of particles"] and scan.warnings == ["Careful: dt large"]
    assert [p.name for p in adapter.vtk_files(run)] == ["p_0.vtp", "p_10.vtp", "p_20.vtp"]
    with pytest.raises(UserError, match=r"energy\.csv: no thermo column for 'step' \(columns: it, n, Et, Er, extra\)"):
        GenericAdapter({**config, "thermo": {"csv": "out/energy.csv", "delimiter": "whitespace"}}).read_thermo(run)


@needs_lammps
@pytest.mark.lammps
def test_lammps_through_the_generic_adapter(tmp_path):
    """The head-on impact run by LAMMPS twice: through the LAMMPS adapter and through the generic adapter
    configured by a JSON file; same thermo, same loop time from the log."""
    adapter_file = tmp_path / "lammps-generic.json"
    adapter_file.write_text(json.dumps(LAMMPS_AS_GENERIC))
    case = tmp_path / "cases" / "head_on"
    case.mkdir(parents=True)
    (case / "in.lammps").write_text((PROJECT / "testcases/crosscode/hertz_head_on/in.lammps").read_text())
    (case / "run.config").write_text(json.dumps({"runs": [{"name": "damped", "script": "in.lammps",
                                                           "variables": {"c": 0.366651, "damping": "tsuji"}}]}))
    targets = tmp_path / "targets"
    targets.mkdir()
    common = {"recipe": "system", "executable": "/usr/bin/lmp", "testcases": [str(tmp_path / "cases")]}
    (targets / "native.json").write_text(json.dumps({**common, "engine": "lammps"}))
    (targets / "generic.json").write_text(json.dumps({**common, "engine": f"generic:{adapter_file}",
                                                      "reference": "native"}))
    home = tmp_path / "home"
    harness(home, "run", "native", "generic", targets=targets)
    native = records(home, "native")["cases/head_on/damped"]
    generic = records(home, "generic")["cases/head_on/damped"]
    assert generic["adapter"] == f"generic:{adapter_file}" and generic["state"] == "post_processed"
    a, b = series(native, "thermo"), series(generic, "thermo")
    assert a["step"] == b["step"] and len(a["step"]) == 151
    for key in ("atoms", "ke", "rke"):
        assert a[key] == b[key], key
    # the same log read by the LAMMPS adapter gives the same loop and pair time
    from pathlib import Path

    lammps_timing = get_adapter("lammps").read_timing(Path(generic["folder"]))
    assert generic["timing"]["total"] == lammps_timing["total"] > 0
    assert generic["timing"]["pair"] == lammps_timing["pair"] > 0
    check = harness(home, "check", "generic", targets=targets)
    assert "1 passed" in check.stdout


def _plugin(folder, body: str, value: str) -> dict:
    """An installed distribution in ``folder`` declaring adapter 'toy' in the entry-point group."""
    (folder / "toy_adapter.py").write_text(textwrap.dedent(body))
    info = folder / "toy_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[dem_harness.adapters]\ntoy = {value}\n")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(folder), str(PROJECT)])}


def test_adapter_from_an_entry_point(tmp_path):
    env = _plugin(tmp_path, """
        from harness.adapters.lammps import LammpsAdapter

        class ToyAdapter(LammpsAdapter):
            name = "toy"

            def log_file(self):
                return "log.toy"
        """, "toy_adapter:ToyAdapter")
    code = ("from harness.adapters import get_adapter, known_adapters; a = get_adapter('toy'); "
            "print(type(a).__name__, a.log_file(), 'toy' in known_adapters())")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert out.stdout.split() == ["ToyAdapter", "log.toy", "True"], out.stderr


def test_broken_entry_point_is_one_line(tmp_path):
    env = _plugin(tmp_path, "class NotAnAdapter:\n    pass\n", "toy_adapter:NotAnAdapter")
    code = ("from harness.adapters import get_adapter\ntry:\n    get_adapter('toy')\n"
            "except Exception as exc:\n    print(type(exc).__name__, exc)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == ("UserError engine adapter 'toy': entry point 'toy_adapter:NotAnAdapter' of group "
                                  "dem_harness.adapters is not an EngineAdapter subclass"), out.stderr
