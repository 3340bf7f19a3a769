"""End to end through the CLI on a temporary git repository holding a fake engine at three revisions.

v1 is the reference; v2 changes gravity by 1e-5 relative (consistent); v3 changes it by 30 % (not). A
second test case folder holds every fault the harness must survive: a segfault, a hang, an error line with
exit code 0, no thermo output, non-finite values, non-UTF-8 output, a failing post script, a missing
script, a failed dependency. Each gets its state and reason, and the rest of the suite still runs.
"""
import json
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import harness_process
from harness_support import commit_files, fake_engine_source, git_repo

from harness.cli import main

SCENE = [{"command": "create", "heights": [1.0, "${H}"]}, {"command": "warn"},
         {"command": "run", "steps": 400, "every": 20},
         {"command": "write", "file": "post/state.txt", "text": "restitution 0.9 bounces 3\n"}]
POST_SCRIPT = "#!/bin/sh\nprintf 't,value\\n0,1\\n1,2\\n' > post/summary.csv\n"


def fault(commands, **entry):
    return {"scene": [{"command": "create", "heights": [1.0]}, *commands,
                      {"command": "run", "steps": 100, "every": 20}], "entry": entry}


FAULTS = {
    "segfault": fault([{"command": "crash"}]),
    "hang": fault([{"command": "hang"}], timeout=1),
    "error_exit0": fault([{"command": "error_exit0"}]),
    "no_thermo": fault([{"command": "run", "steps": 10}, {"command": "no_thermo"}]),
    "nan": fault([{"command": "run", "steps": 10}, {"command": "nan"}]),
    "binary_output": fault([{"command": "garbage"}]),
    "post_script_fails": fault([], post_scripts=["scripts/fail.sh"]),
    "bad_input": fault([{"command": "explode"}]),
}


def make_project(root: Path) -> Path:
    """The repository (engine revisions v1..v3, test cases) and a targets folder next to it."""
    repo = git_repo(root / "repo")
    fall = {"name": "init", "script": "scene.json", "variables": {"H": 2.0},
            "data": {"textfiles": ["post/state.txt"]}}
    main_run = {"name": "main", "script": "scene.json", "depends_on": "init", "variables": {"H": 0.5},
                "post_scripts": ["scripts/summary.sh"],
                "data": {"series": [{"name": "summary", "file": "post/summary.csv", "columns": ["t", "value"]}],
                         "plots": [{"name": "value", "xdata": "summary.t", "ydata": ["summary.value"]}],
                         "textfiles": ["post/state.txt"]}}
    files = {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(9.81),
             "cases/fall/scene.json": json.dumps(SCENE), "cases/fall/scripts/summary.sh": POST_SCRIPT,
             "cases/fall/run.config": json.dumps({"runs": [fall, main_run]}),
             "cases/fall/post/restart/bed.restart": "restart data the case needs",
             "cases/fall/post/stale_output.csv": "left over from running the case in place"}
    for name, case in FAULTS.items():
        files[f"cases/faults/{name}/scene.json"] = json.dumps(case["scene"])
        files[f"cases/faults/{name}/scripts/fail.sh"] = "#!/bin/sh\necho 'cannot fit the curve' >&2\nexit 3\n"
        files[f"cases/faults/{name}/run.config"] = json.dumps(
            {"runs": [{"name": "run", "script": "scene.json", **case["entry"]}]})
    files["cases/faults/config/run.config"] = json.dumps({"runs": [
        {"name": "missing_script", "script": "nowhere.json"},
        {"name": "first", "script": "scene.json"},
        {"name": "then", "script": "scene.json", "depends_on": "first"}]})
    files["cases/faults/config/scene.json"] = json.dumps([{"command": "crash"}])
    commit_files(repo, files, "v1", tag="v1")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(9.81 * (1 + 1e-5))}, "v2", tag="v2")
    commit_files(repo, {"engine/__main__.py": fake_engine_source(9.81 * 1.3)}, "v3", tag="v3")
    targets = root / "targets"
    targets.mkdir()
    common = {"repository": str(root / "repo"), "testcases_revision": "v1", "testcases": ["cases/fall"]}
    (targets / "ref.json").write_text(json.dumps({**common, "revision": "v1"}))
    (targets / "good.json").write_text(json.dumps({**common, "revision": "v2", "reference": "ref"}))
    (targets / "bad.json").write_text(json.dumps({**common, "revision": "v3", "reference": "ref"}))
    (targets / "faulty.json").write_text(json.dumps({**common, "revision": "v1", "testcases": ["cases/faults"]}))
    return targets


def harness(targets: Path, *args) -> int:
    return main(["--machine", "m1", "--targets", str(targets), *args])


def junit_cases(path: Path) -> dict:
    tree = ET.parse(path)
    cases = {}
    for suite in tree.getroot():
        for case in suite:
            failure = case.find("failure")
            skipped = case.find("skipped")
            cases[(suite.get("name"), case.get("name"))] = {
                "failure": failure.get("message") if failure is not None else None,
                "type": failure.get("type") if failure is not None else None,
                "skipped": skipped is not None, "out": (case.findtext("system-out") or "")}
    return cases


@pytest.fixture
def project(store):
    return make_project(store)


def test_versions_built_run_and_checked_with_junit(project, store, capsys):
    from harness.store.models import ConsistencyResult, Override, Run

    assert harness(project, "run", "ref", "good", "bad", "-j", "2") == 0
    out = capsys.readouterr()
    assert "6 runs: 6 ok, 0 failed" in out.out and "[####################] 6/6" in out.err
    main_run = Run.objects.get(target__name="good", name="main")
    assert main_run.state == "post_processed" and main_run.warning_count == 1
    assert (Path(main_run.folder) / "post" / "state.txt").is_file()        # dependency's post/ copied in
    assert (Path(main_run.folder) / "post" / "restart" / "bed.restart").is_file()   # part of the test case
    assert not (Path(main_run.folder) / "post" / "stale_output.csv").exists()     # output, not copied
    assert {s.kind for s in main_run.series.all()} == {"thermo", "plot", "textfile"}
    thermo = main_run.series.get(kind="thermo").columns
    assert thermo["step"][:3] == [0, 20, 40] and thermo["atoms"][0] == 2

    junit = store / "junit.xml"
    assert harness(project, "check", "--junit", str(junit)) == 1
    cases = junit_cases(junit)
    assert cases[("good/cases/fall", "main")]["failure"] is None
    assert "consistency level perfect" in cases[("good/cases/fall", "main")]["out"]
    bad = cases[("bad/cases/fall", "init")]
    assert bad["type"] == "inconsistent" and "ke: inconsistent, C = " in bad["failure"]
    assert "first bad step" in bad["failure"]
    assert "WARNING: something to look at" in bad["out"]                   # log tail as system-out
    good_run = Run.objects.get(target__name="good", name="init")
    assert good_run.state == "consistency_checked" and good_run.consistency == "perfect"
    assert good_run.reference_run.target.name == "ref"
    bad_run = Run.objects.get(target__name="bad", name="init")
    ke = ConsistencyResult.objects.get(run=bad_run, quantity="ke")
    assert ke.level == "inconsistent" and ke.value < 0.9 and ke.first_bad_step > 0
    assert bad_run.consistency_min == pytest.approx(min(r.value for r in bad_run.consistency_results.all()
                                                        if r.value is not None))
    # ke of the reference at step k is sum m g (h0 - z); with 30 % more gravity the bodies fall faster
    assert ConsistencyResult.objects.get(run=bad_run, quantity="atoms").level == "perfect"

    # a reviewer accepts the inconsistency: JUnit and the exit code honour it
    for run in Run.objects.filter(target__name="bad"):
        Override.objects.create(run=run, quantity="", reason="gravity changed on purpose")
    assert harness(project, "check", "bad", "--junit", str(junit)) == 0
    cases = junit_cases(junit)
    assert cases[("bad/cases/fall", "init")]["failure"] is None
    assert "someone: gravity changed on purpose - overruled" in cases[("bad/cases/fall", "init")]["out"]

    # nothing to do the second time; naming a target also runs its reference (here: all cached)
    assert harness(project, "run", "good") == 0
    assert "4 already done" in capsys.readouterr().out


def test_every_fault_is_recorded_and_the_rest_still_runs(project, store, capsys):
    from harness.store.models import Run

    assert harness(project, "run", "faulty", "-j", "2") == 1
    captured = capsys.readouterr()
    runs = {r.testcase.path.split("/")[-1] + "/" + r.name: r for r in Run.objects.filter(target__name="faulty")}
    expected = {
        "segfault/run": ("signal", "SIGSEGV"),
        "hang/run": ("timeout", "timed out after 1 s"),
        "error_exit0/run": ("error_line", "ERROR: lost atoms"),
        "no_thermo/run": ("missing_output", "thermo.csv missing"),
        "nan/run": ("non_finite", "column(s) ke"),
        "post_script_fails/run": ("post_script", "exited with code 3: cannot fit the curve"),
        "bad_input/run": ("exit_code", "exit code 2: ERROR: unknown command 'explode'"),
        "config/missing_script": ("config", "$.runs[0].script: script 'nowhere.json' not found"),
        "config/first": ("signal", "SIGSEGV"),
        "config/then": ("dependency", "dependency 'first' failed (signal)"),
    }
    for key, (reason, text) in expected.items():
        run = runs[key]
        assert (run.state, run.failure_reason) == ("failed", reason), key
        assert text in run.failure_message, (key, run.failure_message)
    binary = runs["binary_output/run"]
    assert binary.state == "post_processed"
    assert "\ufffd" in (Path(binary.folder) / "stdout.txt").read_text(errors="replace")
    hang = runs["hang/run"]
    assert hang.wall_time < 5
    assert "config/missing_script" not in captured.err or "nowhere.json" in captured.err
    assert "11 runs: 1 ok, 10 failed" in captured.out
    record = json.loads((Path(runs["segfault/run"].folder) / "run.json").read_text())
    assert record["failure_reason"] == "signal" and record["exit_code"] == -signal.SIGSEGV

    junit = store / "faults.xml"
    assert harness(project, "check", "faulty", "--junit", str(junit)) == 1
    cases = junit_cases(junit)
    assert cases[("faulty/cases/faults/hang", "run")]["type"] == "timeout"
    assert cases[("faulty/cases/faults/binary_output", "run")]["failure"] is None

    # --rerun-failed runs them again; without it, failed runs stay as they are
    assert harness(project, "run", "faulty", "-k", "segfault") == 0
    assert "1 already done" in capsys.readouterr().out
    assert harness(project, "run", "faulty", "-k", "segfault", "--rerun-failed") == 1


def test_unknown_target_and_broken_target_file_are_one_line_errors(project, capsys):
    assert harness(project, "run", "nope") == 1
    err = capsys.readouterr().err
    assert err.strip() == f"harness: error: unknown target 'nope' (known in {project}: bad, faulty, good, ref)"
    (project / "broken.json").write_text('{"revision": "v1",\n "reference": }')
    assert harness(project, "build", "broken") == 1
    assert "broken.json: invalid JSON at line 2 column 15" in capsys.readouterr().err


def test_import_runs_from_another_machine(project, store, tmp_path, capsys):
    from harness.store.models import Run

    assert harness(project, "run", "ref", "-k", "init") == 0
    source = Path(Run.objects.get(target__name="ref", name="init").folder)
    copy = tmp_path / "from-cluster"
    import shutil

    shutil.copytree(source.parents[2], copy)
    assert main(["import", str(copy), "--as-machine", "cluster"]) == 0
    imported = Run.objects.get(machine__name="cluster", name="init")
    assert imported.state == "post_processed" and imported.folder.startswith(str(copy))
    assert imported.series.get(kind="thermo").columns["atoms"][0] == 2
    assert main(["--machine", "cluster", "list"]) == 0
    assert "cases/fall  init" in capsys.readouterr().out


def test_dask_scheduler(project, store, capsys):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        assert harness(project, "run", "ref", "--scheduler", cluster.scheduler_address) == 0
    assert "2 runs: 2 ok" in capsys.readouterr().out


def test_interrupt_records_runs_in_flight_and_a_rerun_picks_them_up(store, tmp_path):
    repo = git_repo(tmp_path / "repo")
    scene = [{"command": "create", "heights": [1.0]}, {"command": "hang"}, {"command": "run", "steps": 10}]
    commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(),
                        "cases/slow/scene.json": json.dumps(scene),
                        "cases/slow/run.config": json.dumps({"runs": [{"name": "r", "script": "scene.json"}]})},
                 "v1")
    targets = tmp_path / "targets"
    targets.mkdir()
    (targets / "t.json").write_text(json.dumps({"repository": str(repo.working_tree_dir),
                                                "testcases": ["cases"]}))
    env = {**os.environ, "HARNESS_HOME": str(tmp_path / "home2"), "PYTHONPATH": str(Path(__file__).parents[2])}
    command = [sys.executable, "-m", "harness.cli", "--machine", "m1", "--targets", str(targets), "run"]
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=harness_process.as_from_a_terminal)
    runs = tmp_path / "home2" / "runs" / "m1" / "t"
    deadline = time.monotonic() + 60
    while not list(runs.glob("*/cases/slow/r.*/log.dem")) and time.monotonic() < deadline:
        time.sleep(0.1)
    # runs/<machine>/<target>/<build>/<test case>/<run>.<content hash>/
    folder = next(runs.glob("*/cases/slow/r.*"))
    time.sleep(0.3)
    process.send_signal(signal.SIGINT)
    _out, err = process.communicate(timeout=30)
    assert process.returncode == 130, err
    record = json.loads((folder / "run.json").read_text())
    assert (record["state"], record["failure_reason"]) == ("failed", "interrupted")
    listing = subprocess.run([*command[:-1], "list"], env=env, capture_output=True, text=True).stdout
    assert "failed  interrupted" in listing
    # the engine (sleeping 60 s) was killed with its process group
    ps = subprocess.run(["pgrep", "-f", str(folder)], capture_output=True, text=True).stdout
    assert ps.strip() == ""
    # working-tree test cases: fix the scene; the rerun picks up the interrupted run without --rerun-failed
    Path(repo.working_tree_dir, "cases/slow/scene.json").write_text(json.dumps([scene[0], scene[2]]))
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "1 runs: 1 ok" in done.stdout
    # the edited scene is other test case content: a new run folder, the interrupted run's files kept
    assert json.loads((folder / "run.json").read_text())["failure_reason"] == "interrupted"
    assert len(list(runs.glob("*/cases/slow/r.*/run.json"))) == 2
