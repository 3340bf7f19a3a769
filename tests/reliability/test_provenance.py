"""Every verdict fresh and attributable: a changed test case is run again, the current build is the build of
the revision's commit now, run folders are kept per build, gc removes files by its policy and never store
rows, and import never silently replaces a stored record. All through the real CLI."""
import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from provenance_support import RUNS, harness, make_project, rows, scene, write_target


@pytest.fixture
def project(tmp_path):
    return make_project(tmp_path)


def _ok(result):
    assert result.returncode == 0, result.stdout + result.stderr
    return result


def test_an_edited_scene_is_run_again_and_check_never_scores_old_results(project):
    _ok(harness(project, "run", "dev"))
    _ok(harness(project, "check", "dev"))
    # a 30 % taller drop: other physics, other test case content
    (project["root"] / "cases/c0/scene.json").write_text(scene(1.3))
    stale = harness(project, "check", "dev", "-v")  # -v: whole messages (wrapped), the table cuts them
    assert stale.returncode == 1
    assert "stale: the test case changed since this run" in " ".join(stale.stdout.split())
    # only the reference was refreshed: dev's check has no reference of this content to score against...
    _ok(harness(project, "run", "ref"))
    # ...and dev's own runs of c0 are re-run, not "already done"
    again = _ok(harness(project, "run", "dev", "--no-reference"))
    assert "2 runs: 2 ok" in again.stdout and "2 already done" in again.stdout
    checked = _ok(harness(project, "check", "dev"))
    assert "stale" not in checked.stdout
    # the earlier content's runs are kept (outdated, replaced), each with its own folder
    c0 = [r for r in rows(project, RUNS + " WHERE t.name = 'dev' AND tc.path = 'cases/c0'")]
    assert len(c0) == 4 and sorted(r[7] for r in c0) == [0, 0, 1, 1]
    assert len({r[6] for r in c0}) == 4 and all(Path(r[6], "run.json").is_file() for r in c0)


def test_a_stale_reference_is_never_scored_against(project):
    _ok(harness(project, "run", "dev"))
    (project["root"] / "cases/c1/scene.json").write_text(scene(2.0))
    _ok(harness(project, "run", "dev", "--no-reference"))
    result = harness(project, "check", "dev")
    assert result.returncode == 1
    assert "stale reference run: ref cases/c1/a" in result.stderr
    assert "reference run(s) of 'ref' are stale" in result.stderr
    # nothing of c1 was compared with the old content's reference run
    scored = rows(project, """SELECT COUNT(*) FROM harness_consistencyresult cr JOIN harness_run r ON cr.run_id = r.id
                              JOIN harness_testcase tc ON r.testcase_id = tc.id WHERE tc.path = 'cases/c1'""")
    assert scored == [(0,)]


def test_revisions_a_b_a_every_command_agrees_on_the_current_build(project):
    v1, v2 = project["v1"], project["v2"]
    _ok(harness(project, "run", "dev"))
    write_target(project["targets"], "dev", revision="v2", repo=project["repo"], reference="ref")
    _ok(harness(project, "run", "dev"))
    assert harness(project, "check", "dev").returncode == 1  # v2 is inconsistent
    write_target(project["targets"], "dev", revision="v1", repo=project["repo"], reference="ref")
    # v1 is built already: nothing runs again, and its results count again
    build = _ok(harness(project, "build", "dev"))
    assert build.stdout.startswith(f"dev: {v1[:12]}")
    status = _ok(harness(project, "status"))
    dev_row = next(line for line in status.stdout.splitlines() if line.startswith("dev "))
    assert v1[:10] in dev_row and v2[:10] not in dev_row
    listing = _ok(harness(project, "list", "dev")).stdout
    assert v1[:10] in listing and v2[:10] not in listing
    check = _ok(harness(project, "check", "dev", "--junit", str(project["home"] / "junit.xml")))
    table = [line for line in check.stdout.splitlines() if line.startswith("dev ")]
    assert len(table) == 4 and all(v1[:10] in line and f"ref@{v1[:10]}" in line for line in table)
    again = _ok(harness(project, "run", "dev"))
    assert "0 runs" in again.stdout and "8 already done" in again.stdout  # dev and its reference
    # the JUnit report names the commit it was computed on
    suites = ET.parse(project["home"] / "junit.xml").getroot().findall("testsuite")
    properties = {(p.get("name"), p.get("value")) for s in suites for p in s.iter("property")}
    assert {("target", "dev"), ("target_commit", v1), ("reference", "ref"), ("reference_commit", v1)} <= properties
    assert all(case.get("classname").startswith("dev.cases.") for s in suites for case in s.iter("testcase"))
    assert all(f"dev at {v1[:10]}" in (case.findtext("system-out") or "") for s in suites for case in s.iter("testcase"))
    # v2's run folders are kept beside v1's (a folder per build)
    folders = {r[4]: r[6] for r in rows(project, RUNS + " WHERE t.name = 'dev'")}
    assert set(folders) == {v1, v2} and all(Path(f, "run.json").is_file() for f in folders.values())


def test_gc_removes_old_builds_files_by_its_policy_and_keeps_every_row(project):
    _ok(harness(project, "run", "dev"))
    write_target(project["targets"], "dev", revision="v2", repo=project["repo"], reference="ref")
    _ok(harness(project, "run", "dev"))
    before = rows(project, RUNS)
    dry = _ok(harness(project, "gc", "--keep-builds", "0", "--dry-run"))
    assert "would remove 4 run folders and 1 build folders" in dry.stdout
    assert all(Path(r[6]).is_dir() for r in before)
    _ok(harness(project, "gc", "--keep-builds", "0"))
    after = rows(project, RUNS)
    assert after == before  # no store row deleted or changed
    for target, _case, _run, _hash, commit, _state, folder, _replaced in after:
        assert Path(folder).is_dir() == (target == "ref" or commit == project["v2"])


def test_import_reports_a_conflicting_record_and_keeps_the_stored_one(project, tmp_path):
    _ok(harness(project, "run", "ref"))
    (folder,) = [r[6] for r in rows(project, RUNS + " WHERE tc.path = 'cases/c0' AND r.name = 'a'")]
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy / "a")
    record = json.loads((copy / "a" / "run.json").read_text())
    record["wall_time"] = 0.001  # an edited copy: not what was recorded here
    (copy / "a" / "run.json").write_text(json.dumps(record))
    (copy / "broken").mkdir()
    (copy / "broken" / "run.json").write_text(json.dumps({**record, "run": "x", "state": "passed"}))
    (copy / "nan").mkdir()
    (copy / "nan" / "run.json").write_text(json.dumps({**record, "run": "y"}).replace('"wall_time": 0.001',
                                                                                      '"wall_time": NaN'))
    result = harness(project, "import", str(copy))
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 3 and "Traceback" not in result.stderr
    assert any("conflict: differs from the stored run" in line and "wall_time" in line for line in lines)
    assert any("$.state: unknown state 'passed'" in line for line in lines)
    assert any("NaN is not valid JSON" in line for line in lines)
    stored = rows(project, "SELECT wall_time, folder FROM harness_run WHERE folder = ?", folder)
    assert stored and stored[0][0] != 0.001
    # the same record again is no conflict; --replace takes the edited one
    assert "conflict" not in harness(project, "import", str(Path(folder).parent)).stderr
    _ok(harness(project, "import", str(copy / "a"), "--replace"))
    assert rows(project, "SELECT wall_time FROM harness_run WHERE folder = ?", str(copy / "a")) == [(0.001,)]


def test_junit_validates_against_the_jenkins_xunit_schema(project):
    xmlschema = pytest.importorskip("xmlschema")
    schema_file = Path(__file__).resolve().parents[3] / "shared" / "schemas" / "junit-10.xsd"
    if not schema_file.is_file():
        pytest.skip(f"{schema_file} (the Jenkins xunit plugin's schema) is not on this machine")
    # v2 is inconsistent: failures with their messages beside passing runs of the reference
    write_target(project["targets"], "dev", revision="v2", repo=project["repo"], reference="ref")
    harness(project, "run", "dev")
    junit = project["home"] / "junit.xml"
    assert harness(project, "check", "--junit", str(junit)).returncode == 1
    schema = xmlschema.XMLSchema(str(schema_file))
    errors = list(schema.iter_errors(str(junit)))
    assert errors == [], errors[:3]
    root = ET.parse(junit).getroot()
    assert root.get("tests") == "8" and root.get("failures") == "4"
    assert all(len(case.get("time").split(".")[1]) == 3 for case in root.iter("testcase"))
