"""What the CLI prints, through the real CLI on a temporary git repository with the fake engine: tables fit
120 columns unless ``--wide``, ``check -v`` prints whole messages, an overruled run names its reviewer and
reason, the first runs of a new build say that kernels compile, ``status --help`` explains its columns."""
import json
from pathlib import Path

import pytest
from harness_support import commit_files, fake_engine_source, git_repo

from harness.cli import main

#: a deep test case folder, as real suites have: its path alone is 80 characters
CASE = "cases/granular_flow/rotating_drum_with_lifters/hertz_mindlin_rolling_friction/fall"
SCENE = [{"command": "create", "heights": [1.0, "${H}"]}, {"command": "run", "steps": 200, "every": 20}]


def make_project(root: Path) -> Path:
    repo = git_repo(root / "repo")
    runs = [{"name": "a_long_run_configuration_name", "script": "scene.json", "variables": {"H": 2.0}}]
    commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(9.81),
                        f"{CASE}/scene.json": json.dumps(SCENE),
                        f"{CASE}/run.config": json.dumps({"runs": runs})}, "v1", tag="v1")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(9.81 * 1.3)}, "v2", tag="v2")
    targets = root / "targets"
    targets.mkdir()
    common = {"repository": str(root / "repo"), "testcases_revision": "v1", "testcases": ["cases"]}
    (targets / "reference_release.json").write_text(json.dumps({**common, "revision": "v1"}))
    (targets / "development_branch.json").write_text(json.dumps({**common, "revision": "v2",
                                                                 "reference": "reference_release"}))
    return targets


def harness(targets: Path, *args) -> int:
    return main(["--machine", "m1", "--targets", str(targets), *args])


def widest(text: str) -> int:
    return max(len(line) for line in text.splitlines())


@pytest.fixture
def project(store):
    return make_project(store)


def test_tables_fit_120_columns_and_messages_are_whole_on_request(project, capsys):
    from django.contrib.auth import get_user_model

    from harness.store.models import Override, Run

    assert harness(project, "run") == 0
    out = capsys.readouterr()
    # the first runs of each new build say why they are slow to start
    assert out.err.count("first runs of this build: the engine compiles its kernels") == 2
    assert widest(out.out) <= 120
    # progress lines too: the run's name is cut in its middle, its end (the run name) kept
    assert widest(out.err) <= 120 and "…" in out.err and "a_long_run_configuration_name: post-processed" in out.err
    assert harness(project, "--wide", "run", "development_branch", "--all", "--no-reference") == 0
    wide = capsys.readouterr().err
    assert widest(wide) > 120 and f"development_branch {CASE}/a_long_run_configuration_name: post-processed" in wide

    assert harness(project, "check") == 1
    out = capsys.readouterr().out
    assert widest(out) <= 120
    assert "messages cut to fit: -v prints them whole" in out
    row = next(line for line in out.splitlines() if line.startswith("development_branch"))
    assert " failed " in row and "…" in row

    assert harness(project, "check", "-v") == 1
    out = capsys.readouterr().out
    assert widest(out) <= 120
    messages = out[out.index("messages:"):]
    message = Run.objects.get(target__name="development_branch").consistency_results.get(quantity="ke")
    assert f"C = {message.value:.4g}" in messages and "first bad step" in " ".join(messages.split())

    assert harness(project, "--wide", "check") == 1
    wide = capsys.readouterr().out
    assert widest(wide) > 120 and CASE in wide and "…" not in wide

    # a reviewer overrules the inconsistency: the run reads overruled, with reviewer and reason first
    reviewer = get_user_model().objects.create_user("alice")
    Override.objects.create(run=Run.objects.get(target__name="development_branch"), user=reviewer, quantity="",
                            reason="gravity raised on purpose")
    assert harness(project, "check", "-v") == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("development_branch"))
    assert " overruled " in row
    assert row.split(" overruled ")[1].split()[2:4] == ["alice:", "gravity"]  # reviewer and reason first
    assert "alice: gravity raised on purpose - overruled ke (inconsistent)" in " ".join(out.split())

    assert harness(project, "status") == 0
    out = capsys.readouterr().out
    assert widest(out) <= 120 and "older" in out.splitlines()[0] and "development_branch" in out


def test_status_help_explains_every_column(capsys):
    with pytest.raises(SystemExit):
        main(["status", "--help"])
    out = capsys.readouterr().out
    assert widest(out) <= 120
    for heading in ("current build", "not exec", "executed", "failed", "post-proc", "checked", "outdated", "older"):
        assert f"\n  {heading} " in out, heading


def test_ci_prints_the_commit_page_of_each_build_when_a_dashboard_is_configured(project, capsys, monkeypatch):
    from harness.store.models import Build

    assert harness(project, "ci", "--junit", str(project.parent / "junit.xml")) == 1
    assert "dashboard:" not in capsys.readouterr().out  # no dashboard URL: no link
    monkeypatch.setenv("HARNESS_DASHBOARD_URL", "https://ci.example.org/dem/")
    assert harness(project, "ci", "--junit", str(project.parent / "junit.xml")) == 1
    out = capsys.readouterr().out
    commit = Build.objects.get(target__name="development_branch", current=True).commit
    assert (f"dashboard: development_branch at {commit[:10]}: "
            f"https://ci.example.org/dem/commits/development_branch/{commit}/?machine=m1") in out


def test_repeat_keeps_every_stepping_time(project, capsys):
    """``harness run --repeat 3``: each engine runs three times; the three stepping times are stored (the fake
    engine reports 2 ms each time) and the run's stepping time is their median."""
    from harness.store.models import Run

    assert harness(project, "run", "reference_release", "--repeat", "0") == 1
    assert "--repeat must be at least 1" in capsys.readouterr().err
    assert harness(project, "run", "reference_release", "--repeat", "3") == 0
    run = Run.objects.get(target__name="reference_release")
    assert run.timing["stepping_repeats"] == [0.002, 0.002, 0.002] and run.stepping_time == 0.002
    record = json.loads((Path(run.folder) / "run.json").read_text())
    assert record["timing"]["stepping_repeats"] == [0.002, 0.002, 0.002]
    # without --repeat: one stepping time, no repeats
    assert harness(project, "run", "development_branch", "--no-reference") == 0
    assert "stepping_repeats" not in Run.objects.get(target__name="development_branch").timing


def test_a_progress_line_cuts_the_message_first_then_the_name_in_its_middle():
    from harness.report import textout

    before, name, after, end = "[####] 3/9 ", "dem testcases/walls/sliding_block/run", ": failed", " 1.20 s"
    detail = " (nonzero_exit: ERROR: lost atoms: original 1000 current 998)"
    try:
        textout.set_width(100)                                              # the message is cut, not the name
        line = textout.fit_line(before, name, after, detail, end)
        assert len(line) == 100 and name in line and "(nonzero_exit: ERROR: lost atoms:" in line
        textout.set_width(70)          # the message keeps its first 24 characters, the name is cut in its middle
        line = textout.fit_line(before, name, after, detail, end)
        assert len(line) == 70 and line.startswith(before + "dem testc…") and "_block/run: failed" in line
        assert line.endswith(" (nonzero_exit: ERROR: …" + end)
        textout.set_width(40)                         # narrow: the name keeps 10 characters, the message the rest
        line = textout.fit_line(before, name, after, detail, end)
        assert len(line) == 40 and "k/run: failed (n…" + end in line
        textout.set_width(None)
        assert textout.fit_line(before, name, after, detail, end) == before + name + after + detail + end
    finally:
        textout.set_width(textout.DEFAULT_WIDTH)


def test_the_time_left_expects_each_run_its_own_last_wall_time():
    """The estimate a starting run prints: a run that took 290 s last time is not the mean of the short ones."""
    from harness.execution.scheduler import Task, time_left

    hopper = Task(("liggghts", "scenes/hopper", "D28", "c"), None, expected=290.0)
    drop = Task(("liggghts", "walls/drop", "main", "c"), None, expected=1.0)
    new = Task(("liggghts", "walls/new", "main", "c"), None)
    assert time_left([hopper, drop], durations=[1.0, 2.0], slots=2) == 290.0   # the longest run bounds it
    assert time_left([drop, new], durations=[1.0, 3.0], slots=2) == 2.0        # a new run: the mean so far
    assert time_left([drop] * 6, durations=[], slots=2) == 3.0                 # six 1 s runs on two slots
    assert time_left([new], durations=[], slots=2) is None                     # nothing to go by
    assert time_left([hopper, drop], durations=[1.0], slots=2, factor=1.5) == 435.0  # runs so far took 1.5x


def test_the_time_left_scales_expected_times_by_the_pace_of_the_runs_so_far():
    from harness.execution.scheduler import pace

    assert pace([]) == 1.0
    assert pace([(50.0, 62.0), (32.0, 50.0), (140.0, 238.0)]) == 350.0 / 222.0   # sums, not a mean of ratios
    assert pace([(0.0, 3.0)]) == 1.0                                             # nothing expected to go by
