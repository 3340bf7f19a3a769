"""The harness' own cost per run beyond the engine process (goal: below 0.2 s).

A trivial engine (a shell script that copies a 1,000-row thermo table and writes a log) is run N times
through the real machinery - run folder preparation, subprocess, log scan, thermo into pandas, post-
processing, run.json, the store (SQLite) - with one job at a time. Overhead per run = (harness wall time -
sum of engine wall times) / N. The build, discovery and store set-up happen once and are reported apart.

    python benchmarks/harness_overhead.py [N]
"""
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ENGINE = """#!/bin/sh
# -in SCRIPT -log FILE: the "scene" is the thermo table itself
cp "$2" thermo.csv
echo '{"pair": 0, "total": 0}' > timing.json
echo "run done" > "$4"
"""


def main(runs: int = 50):
    workspace = Path(tempfile.mkdtemp(prefix="harness-overhead-"))
    os.environ["HARNESS_HOME"] = str(workspace / "home")
    engine = workspace / "engine.sh"
    engine.write_text(ENGINE)
    engine.chmod(0o755)
    cases = workspace / "cases"
    rows = "\n".join(f"{k * 100},{k * 1e-3},1000,{1.0 / (k + 1)},0.0" for k in range(1000))
    for i in range(runs):
        case = cases / f"case{i:03d}"
        case.mkdir(parents=True)
        (case / "scene.json").write_text("step,time,atoms,ke,rke\n" + rows + "\n")
        (case / "run.config").write_text(json.dumps({"runs": [{"name": "run", "script": "scene.json"}]}))
    targets = workspace / "targets"
    targets.mkdir()
    (targets / "trivial.json").write_text(json.dumps({"recipe": "system", "executable": str(engine),
                                                      "engine": "dem", "testcases": [str(cases)]}))

    from harness.store import setup_store

    start = time.perf_counter()
    setup_store()
    from harness.config.targets import load_target_file
    from harness.execution.scheduler import (
        RunOptions,
        RunReport,
        execute_tasks,
        plan_target,
    )

    target = load_target_file(targets / "trivial.json")
    report = RunReport()
    tasks = plan_target(target, RunOptions(machine="bench"), report, lambda text: None)
    setup = time.perf_counter() - start
    devnull = open(os.devnull, "w")
    start = time.perf_counter()
    execute_tasks(tasks, RunOptions(machine="bench"), report, out=devnull)
    total = time.perf_counter() - start
    engine_time = sum(r.wall_time for r in report.records)
    assert all(r.state == "post_processed" for r in report.records), report.records[0].failure_message
    print(f"{runs} runs, 1,000 thermo rows each, 1 job")
    print(f"store set-up, build and discovery (once):   {setup:.3f} s")
    print(f"harness wall time for the runs:             {total:.3f} s")
    print(f"engine process wall time (sum):             {engine_time:.3f} s")
    print(f"overhead per run beyond the engine process: {(total - engine_time) / runs * 1e3:.1f} ms (goal < 200 ms)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)
