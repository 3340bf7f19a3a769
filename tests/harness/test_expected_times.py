"""The wall times shipped with the repository (harness/execution/expected.py): a workspace with no record of a
run still starts its long runs first; a run's own last wall time on this machine wins over the shipped one.
Through the real CLI on a git repository with the fake engine."""
import json
import re
from pathlib import Path

import pytest
from harness_support import commit_files, fake_engine_source, git_repo

from harness.cli import main
from harness.execution import expected
from harness.execution.expected import expected_times, shipped_times

SCENE = [{"command": "create", "heights": [1.0, 2.0]}, {"command": "run", "steps": 100, "every": 20}]
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def project(store):
    repo = git_repo(store / "repo")
    files = {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source()}
    for case in ("quick", "slow"):  # planned in this order (sorted folders)
        files[f"cases/{case}/scene.json"] = json.dumps(SCENE)
        files[f"cases/{case}/run.config"] = json.dumps({"runs": [{"name": "fall", "script": "scene.json"}]})
    commit_files(repo, files, "two cases", tag="v1")
    targets = store / "targets"
    targets.mkdir()
    (targets / "dem.json").write_text(json.dumps({"repository": str(repo.working_dir), "revision": "v1",
                                                  "testcases": ["cases"]}))
    return targets


@pytest.fixture
def shipped(tmp_path, monkeypatch):
    path = tmp_path / "expected_times.json"
    path.write_text(json.dumps({"measured": "test", "seconds": {"dem": {"cases/slow": {"fall": 300.0},
                                                                         "cases/quick": {"fall": 2.0}}}}))
    monkeypatch.setattr(expected, "SHIPPED", path)
    expected._read_shipped.cache_clear()
    yield path
    expected._read_shipped.cache_clear()


def started(output: str) -> list[str]:
    """The runs in the order of their start lines (stderr)."""
    return re.findall(r"^start dem@\w+ (\S+)", output, re.M)


def test_a_fresh_workspace_starts_the_run_shipped_as_longest_first(project, shipped, capsys):
    assert main(["--machine", "m1", "--targets", str(project), "run", "-j", "2"]) == 0
    assert started(capsys.readouterr().err) == ["cases/slow/fall", "cases/quick/fall"]


def test_without_figures_the_planned_order_holds(project, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(expected, "SHIPPED", tmp_path / "none.json")
    expected._read_shipped.cache_clear()
    assert main(["--machine", "m1", "--targets", str(project), "run", "-j", "2"]) == 0
    assert started(capsys.readouterr().err) == ["cases/quick/fall", "cases/slow/fall"]


def test_the_last_wall_time_on_this_machine_wins(project, shipped):
    assert expected_times("dem", "m1") == {("cases/slow", "fall"): 300.0, ("cases/quick", "fall"): 2.0}
    assert main(["--machine", "m1", "--targets", str(project), "run", "-k", "cases/slow"]) == 0
    times = expected_times("dem", "m1")
    assert times[("cases/quick", "fall")] == 2.0
    assert times[("cases/slow", "fall")] < 60.0       # the fake engine's run, not the 300 s shipped
    assert expected_times("dem", "other machine")[("cases/slow", "fall")] == 300.0


def test_the_shipped_file_names_targets_and_runs_of_this_repository():
    times = json.loads(expected.SHIPPED.read_text())["seconds"]
    assert times, "no shipped wall times"
    for target, cases in times.items():
        assert (ROOT / "targets" / f"{target}.json").exists(), target
        for case, runs in cases.items():
            if not (ROOT / case / "run.config").exists():
                # a run.config the adapter generates (the liggghts target's input scripts, liggghts-doc examples)
                assert (ROOT / case).is_dir() or not case.startswith("testcases/"), f"{target}: {case}"
                continue
            config = json.loads((ROOT / case / "run.config").read_text())
            names = {run["name"] for run in config["runs"]}
            for name, seconds in runs.items():
                # a sweep point is named run@VARIABLE=value
                assert name.split("@")[0] in names, f"{target}: {case}/{name}"
                assert seconds >= 0
    assert shipped_times("dem")
