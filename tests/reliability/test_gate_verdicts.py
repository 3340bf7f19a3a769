"""A verdict a CI can gate on covers every selected run configuration: broken run.configs and runs that never
ran are failures (unless --allow-missing), on a real store left by a `harness run -j 2` killed with SIGKILL, and
`harness check --junit` and the dashboard's /junit.xml are the same bytes on that store."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

from provenance_support import (
    ROOT,
    harness,
    harness_command,
    make_project,
    rows,
    write_target,
)

DASHBOARD_JUNIT = """
import json, django
django.setup()
from django.test import Client
from harness.store.models import Machine, Target
client = Client()
query = {"machine": Machine.objects.get(name="m1").pk, "target": Target.objects.get(name="solo").pk, **EXTRA}
response = client.get("/junit.xml", query)
assert response.status_code == 200, response.status_code
print(json.dumps(response.content.decode()))
"""


def _env(project, **extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("DJANGO_SETTINGS_MODULE", "HARNESS_DATABASE_URL")}
    env.update({"PYTHONPATH": str(ROOT), "HARNESS_HOME": str(project["home"]), **extra})
    return env


def dashboard_junit(project, **extra) -> str:
    done = subprocess.run([sys.executable, "-c", f"EXTRA = {extra!r}\n" + DASHBOARD_JUNIT], cwd=ROOT,
                          capture_output=True, text=True, timeout=300,
                          env=_env(project, DJANGO_SETTINGS_MODULE="webfrontend.settings"))
    assert done.returncode == 0, done.stdout + done.stderr
    return json.loads(done.stdout)


def _cases(junit: str) -> dict:
    out = {}
    for case in ET.fromstring(junit).iter("testcase"):
        failure, skipped = case.find("failure"), case.find("skipped")
        status = "failed" if failure is not None else "skipped" if skipped is not None else "passed"
        out[f"{case.get('classname')}/{case.get('name')}"] = (status, failure.get("type") if failure is not None
                                                               else "")
    return out


def test_killed_run_and_broken_configs_fail_the_gate_and_both_junits_agree(tmp_path):
    project = make_project(tmp_path, cases=3, sleep=1.5)
    write_target(project["targets"], "solo", revision="v1", repo=project["repo"])
    cases = project["root"] / "cases"
    # a run.config that is not JSON, and one with a broken entry beside a good one
    (cases / "broken").mkdir()
    (cases / "broken" / "run.config").write_text('{"runs": [')
    (cases / "half").mkdir()
    (cases / "half" / "scene.json").write_text((cases / "c0" / "scene.json").read_text())
    (cases / "half" / "run.config").write_text(json.dumps({"runs": [
        {"name": "good", "script": "scene.json"}, {"name": "bad", "script": "scene.json", "timeout": "soon"}]}))
    assert harness(project, "build", "solo").returncode == 0
    # a real `harness run -j 2`, killed with SIGKILL while its first two runs are in flight
    process = subprocess.Popen(harness_command(project, "run", "solo", "-j", "2", "-k", "c"), cwd=ROOT,
                               env=_env(project), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if (project["home"] / "harness.sqlite3").exists() and len(rows(
                project, "SELECT id FROM harness_run WHERE started IS NOT NULL AND finished IS NULL")) >= 2:
            break
        time.sleep(0.05)
    os.kill(process.pid, signal.SIGKILL)
    process.wait(timeout=30)
    time.sleep(2)  # the orphaned engines end by themselves

    junit = tmp_path / "junit.xml"
    check = harness(project, "check", "solo", "--junit", str(junit))
    assert check.returncode == 1, check.stdout + check.stderr
    cli = junit.read_text()
    verdicts = _cases(cli)
    # every selected run configuration is there: 3 x 2 runs, the broken file, the half-broken test case
    assert set(verdicts) == {f"solo.cases.c{i}/{r}" for i in range(3) for r in "ab"} | {
        "solo.cases.broken/run.config", "solo.cases.half/good", "solo.cases.half/bad"}, verdicts
    assert verdicts["solo.cases.broken/run.config"] == ("failed", "config")
    assert verdicts["solo.cases.half/bad"] == ("failed", "config")
    assert verdicts["solo.cases.half/good"] == ("failed", "not_executed")
    assert sum(v == ("failed", "not_executed") for v in verdicts.values()) == 7  # 6 of c*, none ran to the end
    assert "passed" not in {status for status, _ in verdicts.values()}
    assert dashboard_junit(project) == cli

    # --allow-missing: runs not executed are skipped, broken configurations still fail; the dashboard agrees
    allowed_xml = tmp_path / "allowed.xml"
    assert harness(project, "check", "solo", "--allow-missing", "--junit", str(allowed_xml)).returncode == 1
    assert dashboard_junit(project, allow_missing="1") == allowed_xml.read_text()
    assert _cases(allowed_xml.read_text())["solo.cases.half/good"] == ("skipped", "")
    allowed = harness(project, "check", "solo", "--allow-missing", "--json")
    assert allowed.returncode == 1
    statuses = {(v["testcase"], v["run"]): v["status"] for v in json.loads(allowed.stdout)}
    assert statuses[("cases/half", "good")] == "skipped" and statuses[("cases/broken", "run.config")] == "failed"
    assert harness(project, "check", "solo", "--allow-missing", "-k", "c0").returncode == 0

    # the runs go, the gate passes once the broken files are mended; the JUnits still agree
    (cases / "broken" / "run.config").write_text(json.dumps({"runs": [{"name": "x", "script": "s.json"}]}))
    (cases / "broken" / "s.json").write_text((cases / "c0" / "scene.json").read_text())
    (cases / "half" / "run.config").write_text(json.dumps({"runs": [{"name": "good", "script": "scene.json"}]}))
    assert harness(project, "run", "solo", "-j", "2").returncode == 0
    check = harness(project, "check", "solo", "--junit", str(junit))
    assert check.returncode == 0, check.stdout + check.stderr
    verdicts = _cases(junit.read_text())
    assert len(verdicts) == 8 and {s for s, _ in verdicts.values()} == {"passed"}, verdicts
    assert dashboard_junit(project) == junit.read_text()


def test_gc_leaves_alone_what_a_running_harness_run_in_another_process_uses(tmp_path):
    project = make_project(tmp_path, cases=2, sleep=1.0)
    write_target(project["targets"], "solo", revision="v1", repo=project["repo"])
    assert harness(project, "run", "solo").returncode == 0           # v1: the current build
    # v2 is not the current build: with --keep-builds 0 its build and run folders are gc's to remove
    process = subprocess.Popen(harness_command(project, "run", "solo@v2", "-j", "2"), cwd=ROOT,
                               env=_env(project), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    in_flight = "SELECT r.folder FROM harness_run r JOIN harness_build b ON r.build_id = b.id " \
                "WHERE b.\"commit\" = ? AND r.started IS NOT NULL AND r.finished IS NULL"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not rows(project, in_flight, project["v2"]):
        time.sleep(0.05)
    flying = rows(project, in_flight, project["v2"])
    assert flying, "the run never started"
    gc = harness(project, "gc", "--keep-builds", "0")
    assert gc.returncode == 0, gc.stdout + gc.stderr
    assert "skipped" in gc.stdout and "in use by another harness process" in gc.stdout, gc.stdout
    assert all(Path(folder).is_dir() for (folder,) in flying)
    builds = project["home"] / "builds" / "solo"
    assert any(p.name.startswith(project["v2"][:12]) for p in builds.iterdir())
    out, err = process.communicate(timeout=300)
    assert process.returncode == 0, out + err
    v2_runs = rows(project, "SELECT r.state, r.folder FROM harness_run r JOIN harness_build b ON r.build_id = b.id "
                            "WHERE b.\"commit\" = ?", project["v2"])
    assert len(v2_runs) == 4 and {state for state, _ in v2_runs} == {"post_processed"}, v2_runs
    # nobody uses v2 now: gc removes its folders and says so
    gc = harness(project, "gc", "--keep-builds", "0")
    assert "skipped" not in gc.stdout, gc.stdout
    assert not any(Path(folder).exists() for _, folder in v2_runs)
    assert not any(p.name.startswith(project["v2"][:12]) for p in builds.iterdir())


def _processes_with(argument: str) -> list[int]:
    found = []
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                if argument.encode() in Path(entry.path, "cmdline").read_bytes().split(b"\0"):
                    found.append(int(entry.name))
            except OSError:
                pass
    return found


def test_a_run_past_its_timeout_fails_and_post_script_daemons_die_with_the_run(tmp_path):
    project = make_project(tmp_path, cases=1)
    write_target(project["targets"], "solo", revision="v1", repo=project["repo"])
    case = project["root"] / "cases" / "c0"
    (case / "daemon.sh").write_text("#!/bin/sh\nsetsid sleep 987.125 >/dev/null 2>&1 < /dev/null &\n")
    (case / "slow_daemon.sh").write_text("#!/bin/sh\nsetsid sleep 987.25 >/dev/null 2>&1 < /dev/null &\n"
                                         "sleep 30\n")
    for script in ("daemon.sh", "slow_daemon.sh"):
        (case / script).chmod(0o755)
    (case / "run.config").write_text(json.dumps({"runs": [
        {"name": "tiny", "script": "scene.json", "timeout": 0.0001},
        {"name": "daemon", "script": "scene.json", "post_scripts": ["daemon.sh"]},
        {"name": "slow", "script": "scene.json", "post_scripts": ["slow_daemon.sh"], "timeout": 4}]}))
    try:
        result = harness(project, "run", "solo")
        assert result.returncode == 1, result.stdout + result.stderr
        states = {run: (state, reason) for run, state, reason in rows(
            project, "SELECT name, state, failure_reason FROM harness_run")}
        # the engine took far longer than 0.1 ms: the run outlived its timeout
        assert states["tiny"] == ("failed", "timeout"), states
        assert states["daemon"] == ("post_processed", ""), states
        assert states["slow"] == ("failed", "post_script"), states
        # neither daemon outlived its run, although both left the post script's session
        assert _processes_with("987.125") == [] and _processes_with("987.25") == []
    finally:
        for pid in _processes_with("987.125") + _processes_with("987.25"):
            os.kill(pid, signal.SIGKILL)
