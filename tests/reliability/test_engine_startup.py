"""An engine that writes no log at all (it did not start, or died before its first line) is a failed run with
its reason and its record, never a harness error."""
import json
import os
import subprocess
import sys
from pathlib import Path

from provenance_support import ROOT


def test_a_code_that_writes_no_log_is_a_failed_run_with_its_record(tmp_path):
    case = tmp_path / "cases" / "quiet"
    case.mkdir(parents=True)
    (case / "in.quiet").write_text("# LIGGGHTS input the program never reads\n")
    (case / "run.config").write_text(json.dumps({"runs": [{"name": "quiet", "script": "in.quiet"}]}))
    targets = tmp_path / "targets"
    targets.mkdir()
    # /bin/true exits 0 and writes nothing: no log.liggghts, no thermo
    (targets / "quiet.json").write_text(json.dumps({"executable": "/bin/true", "engine": "liggghts",
                                                    "testcases": [str(tmp_path / "cases")]}))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HARNESS_HOME", None)
    done = subprocess.run([sys.executable, "-m", "harness.cli", "--home", str(tmp_path / "home"), "--targets",
                           str(targets), "run", "quiet"], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "harness error" not in done.stdout + done.stderr
    (record_file,) = (tmp_path / "home" / "runs").rglob("run.json")
    record = json.loads(record_file.read_text())
    assert (record["state"], record["failure_reason"]) == ("failed", "missing_output")
    assert "no LIGGGHTS log" in record["failure_message"]
    # the engine's private Open MPI session folder is gone again
    assert not any(Path(tmp_path / "home" / "tmp").iterdir())
