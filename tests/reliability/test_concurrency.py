"""Several harness processes on one workspace lose nothing: three real ``harness run`` processes, two on the
same target and one on another, start together on a shared SQLite store; every executed run is stored
exactly once, with its own output, and no process fails with "database is locked"."""
import json
import os
import subprocess
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
