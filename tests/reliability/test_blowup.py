"""A run that has clearly blown up fails by default in the harness too (harness.config.acceptance's default check
``blowup``), on real runs of the bundled engine built from this repository: a gas at 1.5 times the critical
time step fails whether the engine stops it (its own limit) or not (a scene that switches the engine's limit
off is still failed by the harness), and a run.config that declares the hard case passes, the engine getting
the declared limit too."""
from __future__ import annotations

import json

from provenance_support import ROOT, harness, rows
from test_engine_verdicts import gas


def _project(tmp_path, scenes: dict, runs: list) -> dict:
    case = tmp_path / "cases" / "gas"
    case.mkdir(parents=True)
    for name, script in scenes.items():
        (case / name).write_text(json.dumps(script))
    (case / "run.config").write_text(json.dumps({"runs": runs}))
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "engine.json").write_text(json.dumps({
        "repository": str(ROOT), "revision": "HEAD", "recipe": "dem", "source_folder": "engine", "engine": "dem",
        "testcases": [str(tmp_path / "cases")], "testcases_revision": "working-tree"}))
    return {"home": tmp_path / "home", "targets": targets}


def _harness(project, *args):
    return harness(project, *args, timeout=1200)


def test_blown_up_runs_fail_by_default_and_a_declared_hard_case_passes(tmp_path):
    full = gas(1.5, steps=200)
    off = full[:-1] + [{"command": "set", "property": "blowup", "enabled": False}, full[-1]]
    quiet = [c for c in off if c.get("property") != "thermo"]  # no max_overlap column
    project = _project(tmp_path, {"gas.json": gas(1.5, steps=200), "quiet.json": quiet, "off.json": off}, [
        {"name": "engine_stops_it", "script": "gas.json"},
        {"name": "harness_fails_it", "script": "off.json"},
        {"name": "harness_fails_it_from_the_log", "script": "quiet.json",
         "stability": {"finite": True}},
        {"name": "declared_hard_case", "script": "gas.json", "stability": {"blowup": {"max_overlap": 5.0}}}])
    result = _harness(project, "run", "engine", "-j", "2")
    assert result.returncode == 1, result.stdout + result.stderr
    stored = {name: (state, reason, message) for name, state, reason, message in rows(
        project, "SELECT name, state, failure_reason, failure_message FROM harness_run")}
    assert stored["engine_stops_it"][:2] == ("failed", "exit_code")
    assert "blow-up at step" in stored["engine_stops_it"][2]
    # the engine ran to the end (its limit switched off in the scene): the harness' default check fails it
    assert stored["harness_fails_it"][:2] == ("failed", "stability"), stored["harness_fails_it"]
    assert "stability blowup: largest overlap" in stored["harness_fails_it"][2]
    assert "thermo.max_overlap" in stored["harness_fails_it"][2]
    # without a max_overlap column: from the engine's own report in its log, run.config's other checks aside
    assert stored["harness_fails_it_from_the_log"][:2] == ("failed", "stability")
    assert "engine_log.max_overlap" in stored["harness_fails_it_from_the_log"][2]
    # declared: the engine got the limit (DEM_BLOWUP_MAX_OVERLAP) and the harness checks against it
    assert stored["declared_hard_case"][:2] == ("post_processed", ""), stored["declared_hard_case"]
