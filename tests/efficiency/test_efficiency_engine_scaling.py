"""The bundled engine scales over its threads (``harness scaling``): each point runs on as many Numba threads
as it has cores, and the figures are the engine's own loop times (timing.json) by their formulas."""
from __future__ import annotations

import json
import math
import shutil

import pytest
from efficiency_support import ROOT, harness

N = 2500  # above the engine's serial threshold (engine/threads.py SERIAL_BELOW), so 2 threads are used


@pytest.mark.slow
def test_engine_scaling_runs_each_point_on_its_threads_with_the_engines_own_times(tmp_path):
    case = tmp_path / "cases" / "box"
    case.mkdir(parents=True)
    shutil.copy(ROOT / "testcases" / "scaling" / "settling_box" / "scene.json", case)
    half_width = 0.03 * math.sqrt(N / 10000)
    height = N * 4 / 3 * math.pi * 0.0015 ** 3 / (0.28 * (2 * half_width - 0.003) ** 2) + 0.003
    (case / "run.config").write_text(json.dumps({"runs": [{
        "name": "box", "script": "scene.json", "scaling": {"cores": [1, 2]},
        "variables": {"N": N, "SEED": 1, "HALF_WIDTH": half_width, "HEIGHT": height, "DUMP_EVERY": 10 ** 9,
                      "SETTLE_STEPS": 300, "MEASURE_STEPS": 300}}]}))
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "dem.json").write_text(json.dumps({"repository": str(ROOT), "revision": "HEAD",
                                                  "testcases": [str(tmp_path / "cases")]}))
    project = {"targets": targets, "home": tmp_path / "home"}
    result = harness(project, "scaling", "dem", timeout=1500)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "box/box  (strong scaling over threads)" in result.stdout
    totals = {}
    for folder in (tmp_path / "home" / "runs").rglob("box@cores=*"):
        timing = json.loads((folder / "timing.json").read_text())
        cores = int(folder.name.split("=")[1].split(".")[0])
        assert timing["threads"] == cores  # the point ran on its share of threads, not the machine's
        totals[cores] = timing["total"]
    table = json.loads(next((tmp_path / "home" / "scaling").rglob("box.json")).read_text())
    points = {p["cores"]: p for p in table["points"]}
    assert points[1]["time"] == pytest.approx(totals[1], rel=1e-12)
    assert points[2]["speedup"] == pytest.approx(totals[1] / totals[2], rel=1e-12)
    assert points[2]["efficiency"] == pytest.approx(totals[1] / totals[2] / 2, rel=1e-12)
