"""Several harness processes on one workspace lose nothing: three real ``harness run`` processes, two on the
same target and one on another, start together on a shared SQLite store; every executed run is stored
exactly once, with its own output, and no process fails with "database is locked"."""
import json
import os
import subprocess
import sys
from pathlib import Path

from provenance_support import ROOT, RUNS, harness, harness_command, make_project, rows


def test_three_processes_on_one_workspace_store_every_run_exactly_once(tmp_path):
    # runs long enough (0.4 s of sleep in the engine) that the three processes overlap
    project = make_project(tmp_path, cases=4, sleep=0.4)
    # the workspace and both builds exist first, so the three processes compete for runs, not set-up
    assert harness(project, "build").returncode == 0
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HARNESS_HOME", None)
    commands = [harness_command(project, "run", "dev", "--no-reference", "-j", "2"),
                harness_command(project, "run", "dev", "--no-reference", "-j", "2"),
                harness_command(project, "run", "ref", "-j", "2")]
    processes = [subprocess.Popen(c, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                 for c in commands]
    outputs = [p.communicate(timeout=300) for p in processes]
    for process, (out, err) in zip(processes, outputs):
        assert process.returncode == 0, out + err
        assert "database is locked" not in out + err and "Traceback" not in out + err
    # the two processes on dev shared its 8 runs: each ran by exactly one of them, the other waited
    executed = [sum(line.startswith("dev ") for line in out.splitlines()) for out, _ in outputs[:2]]
    assert sum(executed) == 8, executed
    assert any("waiting for another harness process" in err for _, err in outputs[:2]) or 0 in executed
    stored = rows(project, RUNS)
    keys = [(t, case, run, content) for t, case, run, content, *_ in stored]
    assert len(stored) == 16 and len(set(keys)) == 16
    for target, case, run, content, _commit, state, folder, _replaced in stored:
        assert state == "post_processed"
        record = json.loads(Path(folder, "run.json").read_text())
        assert (record["target"], record["testcase"], record["run"], record["testcase_hash"]) == \
            (target, case, run, content)
        # its own output: the thermo file in its folder is the one its record was read from
        thermo = Path(folder, "thermo.csv").read_text().splitlines()
        steps = next(s for s in record["series"] if s["kind"] == "thermo")["columns"]["step"]
        assert len(thermo) - 1 == len(steps)


PLAN_THEN_EXECUTE = """
import subprocess, sys
from pathlib import Path
from harness.execution.workspace import Workspace, use_workspace
home, targets, other = sys.argv[1], Path(sys.argv[2]), sys.argv[3:]
with use_workspace(Workspace.at(home)):
    from harness.store import setup_store
    setup_store()
    from harness.execution.scheduler import RunOptions, RunReport, execute_tasks, plan_target
    from harness.config.targets import load_targets
    report = RunReport()
    tasks = plan_target(load_targets(targets)[0]["dev"], RunOptions(machine="m1", jobs=1), report, print)
    print("planned", len(tasks))
    # another harness process runs every one of them, start to end, before this one executes its plan
    subprocess.run(other, check=True, capture_output=True)
    execute_tasks(tasks, RunOptions(machine="m1", jobs=1), report, sys.stdout)
    print("executed", len(report.records), "skipped", report.skipped)
    for lock in report.in_use:
        lock.release()
"""


def test_a_run_another_process_finished_after_this_one_planned_it_is_not_run_again(tmp_path):
    """The late claim: this process plans a run, another process claims, runs, stores and releases it before
    this one gets to it. Taking the free lock then must not run it a second time."""
    project = make_project(tmp_path, cases=2)
    assert harness(project, "build").returncode == 0
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HARNESS_HOME", None)
    other = harness_command(project, "run", "dev", "--no-reference")
    done = subprocess.run([sys.executable, "-c", PLAN_THEN_EXECUTE, str(project["home"]), str(project["targets"]),
                           *other], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "planned 4" in done.stdout, done.stdout
    assert "executed 0 skipped 4" in done.stdout, done.stdout
    assert len(rows(project, RUNS)) == 4
