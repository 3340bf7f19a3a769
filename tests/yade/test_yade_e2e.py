"""YADE driven end to end through the harness CLI (subprocesses, a throw-away workspace)."""
from __future__ import annotations

import json
import shutil

import pytest

from yade_testing import EXAMPLES, MASS, harness, needs_yade, records, series

pytestmark = [needs_yade, pytest.mark.yade]


@pytest.fixture(scope="module")
def yade_target(tmp_path_factory):
    """``harness run yade`` (two runs, about 6 s) and ``harness check yade``."""
    home = tmp_path_factory.mktemp("home")
    harness(home, "run", "yade", "-j", "2")
    check = harness(home, "check", "yade", check=False)
    return records(home, "yade"), check


def test_every_run_post_processed(yade_target):
    runs, check = yade_target
    assert sorted(runs) == ["testcases/yade/free_fall/fall", "testcases/yade/settling/settle"]
    for name, record in runs.items():
        assert record["state"] == "post_processed", (name, record["failure_message"])
        assert record["adapter"] == "yade" and record["timing"]["total"] > 0
        assert all(v["ok"] for v in record["verdicts"])
    assert check.returncode == 0, check.stdout + check.stderr


def test_free_fall_exact(yade_target):
    runs, _ = yade_target
    thermo = series(runs["testcases/yade/free_fall/fall"], "thermo")
    for step, ke in zip(thermo["step"], thermo["ke"]):
        exact = 0.5 * 32 * MASS * (0.3 ** 2 + 0.1 ** 2 + (9.81 * step * 1e-5) ** 2)
        assert ke == pytest.approx(exact, rel=1e-12)


def test_settling_dumps(yade_target):
    runs, _ = yade_target
    record = runs["testcases/yade/settling/settle"]
    dumps = series(record, "vtk")
    assert dumps["step"] == [0, 1000, 2000, 3000] and dumps["particles"] == [144] * 4
    # the lowest layer (centres 2 mm up, r = 1.5 mm) reaches the floor and stays on it: overlap below 0.1 mm
    assert dumps["z_min"][0] == pytest.approx(0.002, abs=1e-6)
    assert 0.0015 - 1e-4 < min(dumps["z_min"]) < 0.0016


def test_shipped_examples_run_unchanged(tmp_path):
    """A copy of two YADE examples, no run.config: one run per script. billiard.py opens YADE's Qt view
    (most examples do) and fails without a display, with the script line; bouncingbubble.py runs (exit code 0)
    and, like every shipped example, writes no thermo of its own: the launcher records its final state."""
    if not EXAMPLES.is_dir():
        pytest.skip("YADE examples not installed (package yade)")
    folder = tmp_path / "examples"
    folder.mkdir()
    for name in ("billiard.py", "bouncingbubble.py"):
        shutil.copy(EXAMPLES / name, folder)
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "examples.json").write_text(json.dumps({
        "recipe": "system", "executable": "/usr/bin/yade", "engine": "yade", "testcases": [str(folder)]}))
    home = tmp_path / "home"
    result = harness(home, "run", "examples", "-j", "2", targets=targets, check=False)
    assert result.returncode == 1
    runs = records(home, "examples")
    assert sorted(runs) == ["examples/billiard", "examples/bouncingbubble"]
    billiard, bubble = runs["examples/billiard"], runs["examples/bouncingbubble"]
    assert billiard["exit_code"] == 1 and billiard["failure_reason"] == "exit_code"
    assert "ERROR: ImportError: Connecting to DISPLAY at Yade startup failed" in billiard["failure_message"]
    assert "(billiard.py line 55)" in billiard["failure_message"]
    assert bubble["exit_code"] == 0 and bubble["state"] == "post_processed", bubble["failure_message"]
    thermo = series(bubble, "thermo")
    assert thermo["step"] == [0] and thermo["source"] == ["final_state"] and thermo["atoms"][0] > 0
