"""A revision that does not compile is a result CI gates on: `harness run` stores its failed build and records
every selected run failed with reason build_failed (never executed), `harness check --junit` exits 1 with those
runs and one failing test case `build`, the dashboard's /junit.xml is the same bytes, and the overview shows
the target failed. The engine is the fake engine behind the tiny C++ launcher of build_support."""
import json
import shutil
import sqlite3
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from build_support import (CMAKELISTS_LAUNCHER, FAKE_ENGINE, LAUNCHER, ROOT, SCENE, commit_files, git_repo, harness,
                           write_target)

sys.path.insert(0, str(ROOT / "tests" / "reliability"))
from test_gate_verdicts import _cases, _env, dashboard_junit  # noqa: E402  (its /junit.xml client, JUnit reader)

pytestmark = pytest.mark.skipif(not (shutil.which("cmake") and shutil.which("c++")),
                                reason="needs cmake and a C++ compiler (scripts/setup.sh)")

OVERVIEW = """
import django
django.setup()
from django.test import Client
response = Client().get("/")
assert response.status_code == 200, response.status_code
print(response.content.decode())
"""


def test_a_revision_that_does_not_compile_fails_its_runs_and_the_junit_build_case(tmp_path):
    repo = git_repo(tmp_path / "repo")
    run_config = json.dumps({"runs": [{"name": "drop", "script": "scene.json"},
                                      {"name": "again", "script": "scene.json"}]})
    commit_files(repo, {"engine/__main__.py": FAKE_ENGINE, "engine/launcher.cpp": LAUNCHER,
                        "engine/CMakeLists.txt": CMAKELISTS_LAUNCHER, "cases/fall/scene.json": SCENE,
                        "cases/fall/run.config": run_config}, "start")
    write_target(tmp_path, "solo", {"repository": str(repo.working_tree_dir), "revision": "HEAD",
                                    "recipe": "cmake", "source_folder": "engine",
                                    "generated_executable": "fake_engine",
                                    "cmake_options": {"PYTHON": sys.executable}, "engine": "dem",
                                    "testcases": ["cases"], "testcases_revision": "working-tree"})
    home, targets = tmp_path / "home", tmp_path / "targets"
    first = harness(home, targets, "run", "solo")
    assert first.returncode == 0, first.stdout + first.stderr
    broken = commit_files(repo, {"engine/launcher.cpp": LAUNCHER.replace("return 127;", "return undeclared_status;")},
                          "does not compile")

    ran = harness(home, targets, "run", "solo")
    assert ran.returncode == 1
    assert "undeclared_status" in ran.stderr
    junit = tmp_path / "junit.xml"
    check = harness(home, targets, "check", "solo", "--junit", str(junit))
    assert check.returncode == 1, check.stdout + check.stderr
    assert "2 runs: 0 passed, 2 failed" in check.stdout

    with sqlite3.connect(home / "harness.sqlite3") as db:
        runs = db.execute("SELECT r.name, r.state, r.failure_reason, r.failure_message, r.started, b.status, "
                          "b.current FROM harness_run r JOIN harness_build b ON r.build_id = b.id "
                          "WHERE b.\"commit\" = ? ORDER BY r.name", (broken,)).fetchall()
        old = db.execute("SELECT DISTINCT r.state FROM harness_run r JOIN harness_build b ON r.build_id = b.id "
                         "WHERE b.\"commit\" != ?", (broken,)).fetchall()
    assert [r[:3] for r in runs] == [("again", "failed", "build_failed"), ("drop", "failed", "build_failed")]
    assert all("undeclared_status" in r[3] and r[4] is None for r in runs)   # never started
    assert {(r[5], r[6]) for r in runs} == {("failed", 1)}                   # the current build, failed
    assert old == [("outdated",)]                                            # the runs of the build before

    text = junit.read_text()
    cases = _cases(text)
    assert cases == {"solo.cases.fall/drop": ("failed", "build_failed"),
                     "solo.cases.fall/again": ("failed", "build_failed"),
                     "solo.build/build": ("failed", "build_failed")}
    root = ET.fromstring(text)
    assert (root.get("tests"), root.get("failures")) == ("3", "3")
    build_case = next(c for c in root.iter("testcase") if c.get("name") == "build")
    message = build_case.find("failure").get("message")
    assert "launcher.cpp" in message and "error:" in message and "undeclared_status" in message
    assert "--- log tail ---" in build_case.find("system-out").text
    # the dashboard's /junit.xml: the same bytes
    assert dashboard_junit({"home": home}) == text

    overview = subprocess.run([sys.executable, "-c", OVERVIEW], cwd=ROOT, capture_output=True, text=True,
                              timeout=300,
                              env={**_env({"home": home}), "DJANGO_SETTINGS_MODULE": "webfrontend.settings"})
    assert overview.returncode == 0, overview.stderr
    row = overview.stdout[overview.stdout.index('<tr class="target '):]
    row = row[:row.index("</tr>")]
    assert row.startswith('<tr class="target verdict-failed">') and ">solo</a>" in row   # as harness check says
    assert "does not build" in row and "undeclared_status" in row

