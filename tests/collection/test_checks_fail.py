"""Acceptance and stability checks fail when they should, through the harness and the real engine.

A scene whose time step is beyond the critical estimate is stopped by the engine's strict check with a clear
message; a wrong expectation and a lost particle fail their runs with messages naming quantity and bound.
"""
import json
import shutil
import subprocess
import sys

import pytest

from harness.execution.workspace import PROJECT_ROOT

CASES = PROJECT_ROOT / "testcases"

#: two spheres drift at 1 m/s; the one 5 mm from the fixed +x face leaves the domain within 200 steps
DRIFT_OUT = [
    {"command": "create", "object": "domain", "lo": [-0.05, -0.05, -0.05], "hi": [0.05, 0.05, 0.05]},
    {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.3,
     "density": 2500},
    {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5},
    {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "none"},
    {"command": "create", "object": "particle", "type": 1, "radius": 0.002, "position": [0.043, 0, 0],
     "velocity": [1.0, 0, 0]},
    {"command": "create", "object": "particle", "type": 1, "radius": 0.002, "position": [-0.04, 0, 0],
     "velocity": [1.0, 0, 0]},
    {"command": "set", "property": "timestep", "value": 1e-4},
    {"command": "set", "property": "thermo", "every": 20},
    {"command": "run", "steps": 200},
]


def test_bad_runs_fail_with_clear_messages(tmp_path):
    if not (PROJECT_ROOT / ".git").exists():
        pytest.skip("needs the project's git checkout (targets are built from git)")
    case = tmp_path / "cases" / "bad"
    case.mkdir(parents=True)
    shutil.copy(CASES / "stability/near_critical_dt/scene.json", case / "settle.json")
    shutil.copy(CASES / "analytic/free_fall/scene.json", case / "fall.json")
    (case / "drift.json").write_text(json.dumps(DRIFT_OUT))
    (case / "run.config").write_text(json.dumps({"runs": [
        # 0.212 of the Rayleigh time with a strict limit of 0.2
        {"name": "beyond_critical", "script": "settle.json", "variables": {"DT": 4e-5}},
        {"name": "wrong_expectation", "script": "fall.json", "variables": {"DT": 1e-3, "STEPS": 200},
         "expectations": [{"quantity": "thermo.z[1]", "at": "end", "value": 1.5, "rel_tol": 0.01}]},
        {"name": "particle_lost", "script": "drift.json", "stability": {"particle_count": {}}},
        {"name": "fine", "script": "fall.json", "variables": {"DT": 1e-3, "STEPS": 100},
         "stability": {"particle_count": {}}},
    ]}))
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "head.json").write_text(json.dumps(
        {"repository": str(PROJECT_ROOT), "revision": "HEAD", "testcases": [str(tmp_path / "cases")]}))
    home = tmp_path / "home"
    cmd = [sys.executable, "-m", "harness.cli", "--machine", "m", "--home", str(home), "--targets", str(targets)]
    result = subprocess.run(cmd + ["run", "-j", "2"], cwd=PROJECT_ROOT, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 1, result.stdout + result.stderr
    records = {r["run"]: r for r in (json.loads(p.read_text()) for p in home.glob("runs/m/head/**/run.json"))}
    assert set(records) == {"beyond_critical", "wrong_expectation", "particle_lost", "fine"}

    critical = records["beyond_critical"]
    assert critical["state"] == "failed" and critical["failure_reason"] in ("exit_code", "error_line")
    assert "above the allowed fraction 0.2" in critical["failure_message"]
    assert "Rayleigh time" in critical["failure_message"]

    wrong = records["wrong_expectation"]
    assert wrong["state"] == "failed" and wrong["failure_reason"] == "expectation"
    assert "thermo.z[1]" in wrong["failure_message"] and "1.4038" in wrong["failure_message"]
    assert "[1.485, 1.515]" in wrong["failure_message"]

    lost = records["particle_lost"]
    assert lost["state"] == "failed" and lost["failure_reason"] == "stability"
    assert "thermo.atoms lost 1 particles (allowed 0)" in lost["failure_message"]

    assert records["fine"]["state"] == "post_processed"
