"""One rule for a speed change (harness.store.rules.speed_kind): ``harness compare`` and ``bisect --slower`` mark a
stepping-time ratio only beyond the spread of repeated runs (``--repeat N``), as the regressions and the overview
do. Through the real CLI, on a git repository whose second commit's fake engine reports noisy loop times."""
import json
from pathlib import Path

import pytest
from harness_support import commit_files, fake_engine_source, git_repo

from harness.cli import main
from harness.store.rules import speed_kind

SCENE = [{"command": "create", "heights": [1.0, 2.0]}, {"command": "run", "steps": 100, "every": 20}]
#: the second commit's loop times of successive runs: the first alone is 30 % slower than 2 ms; three of them
#: have the median 2.6 ms (1.3x) and spread (3.4 - 2.0) / 2.6 = 54 %
NOISY = [0.0026, 0.0020, 0.0034]


@pytest.fixture
def project(store):
    repo = git_repo(store / "repo")
    runs = [{"name": "fall", "script": "scene.json"}]
    commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(),
                        "cases/drop/scene.json": json.dumps(SCENE),
                        "cases/drop/run.config": json.dumps({"runs": runs})}, "fast", tag="v1")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(stepping=NOISY)}, "noisy and slower", tag="v2")
    targets = store / "targets"
    targets.mkdir()
    (targets / "dem.json").write_text(json.dumps({"repository": str(repo.working_dir), "revision": "v2",
                                                  "testcases_revision": "v1", "testcases": ["cases"]}))
    return targets


def harness(targets: Path, *args) -> int:
    return main(["--machine", "m1", "--targets", str(targets), *args])


def test_the_rule():
    assert speed_kind(1.3) == "slower" and speed_kind(0.7) == "faster" and speed_kind(1.05) == "same"
    assert speed_kind(1.3, noise=0.54) == "same"              # inside the spread of repeated runs
    assert speed_kind(1.3, noise=0.2) == "slower"             # beyond it
    assert speed_kind(1.15, threshold=0.2) == "same"          # bisect --slower 1.2 asks 20 %
    assert speed_kind(None) == "same"


def test_compare_marks_a_slowdown_only_beyond_the_spread(project, capsys):
    assert harness(project, "compare", "dem@v1", "dem@v2", "--json") == 0
    single = json.loads(capsys.readouterr().out)
    assert single["time_ratio"] == pytest.approx(1.3) and single["noise"] == 0 and single["speed"] == "slower"

    assert harness(project, "compare", "dem@v1", "dem@v2", "--repeat", "0") == 1
    assert "--repeat must be at least 1" in capsys.readouterr().err
    # the second commit's run again, three times: median 2.6 ms, spread 54 %
    assert harness(project, "run", "dem@v2", "--repeat", "3") == 0  # stored with one time: runs again
    capsys.readouterr()
    assert harness(project, "compare", "dem@v1", "dem@v2", "--json", "--no-run") == 0
    repeated = json.loads(capsys.readouterr().out)
    assert repeated["pairs"][0]["noise"] == pytest.approx(0.0014 / 0.0026)
    assert repeated["time_ratio"] == pytest.approx(1.3) and repeated["speed"] == "same"
    assert harness(project, "compare", "dem@v1", "dem@v2", "--no-run") == 0
    out = capsys.readouterr().out
    assert "1.300 ±54%" in out
    assert "stepping time B/A 1.300 (geometric mean, spread of repeated runs 54 %: no speed change)" in out


def test_bisect_slower_needs_the_slowdown_beyond_the_spread(project, capsys):
    # one run each: 1.3x GOOD's is beyond 1.2, the commit is the first slow one
    assert harness(project, "bisect", "dem", "v1", "v2", "--slower", "1.2") == 0
    out = capsys.readouterr()
    commit = git_repo_head(project)
    assert f"first bad commit: {commit}" in out.out
    assert "stepping time against GOOD: 1.300x (geometric mean)" in out.out
    # three runs each: 1.3x lies inside the 54 % spread, so BAD is not slower
    assert harness(project, "bisect", "dem", "v1", "v2", "--slower", "1.2", "--repeat", "3") == 1
    err = capsys.readouterr().err
    assert "is not bad against GOOD" in err and "within the spread of repeated runs 54 %" in err


def git_repo_head(targets: Path) -> str:
    import git

    return git.Repo(json.loads((targets / "dem.json").read_text())["repository"]).commit("v2").hexsha
