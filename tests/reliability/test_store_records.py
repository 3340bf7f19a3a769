"""Both stores take and refuse the same run records: on SQLite and on a real PostgreSQL server, a record with a
NUL character is one line and the rest of the folder is imported; a success whose series hold nulls (a NaN run
from elsewhere) is stored as failed; every malformed database URL is one line, without a traceback."""
from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

from provenance_support import ROOT, harness, make_project

sys.path.insert(0, str(ROOT / "tests" / "postgres"))
from pg_server import Server, binaries  # noqa: E402


@pytest.fixture(scope="module")
def postgres_url():
    if binaries() is None:
        pytest.skip("Debian's postgresql server is not installed (scripts/setup.sh installs it)")
    folder = Path(tempfile.mkdtemp(prefix="harness-postgres-"))
    server = Server(folder / "server").start()
    yield server.create_database("harness_records")
    server.stop()
    shutil.rmtree(folder, ignore_errors=True)


def _records(project, folder: Path) -> None:
    """Run folders of a real run, copied; one record gets a NUL byte, one nulls in its thermo series, one a
    commit longer than the store's column."""
    assert harness(project, "run", "dev", "--no-reference").returncode == 0
    shutil.copytree(project["home"] / "runs", folder)
    records = sorted(folder.rglob("run.json"))
    assert len(records) == 4
    bad = json.loads(records[0].read_text())
    bad["failure_message"] = "before\u0000after"
    records[0].write_text(json.dumps(bad))
    long = json.loads(records[2].read_text())
    long["build"]["commit"] = "f" * 65  # longer than the store's commit column
    records[2].write_text(json.dumps(long))
    nan = json.loads(records[1].read_text())
    thermo = next(s for s in nan["series"] if s["kind"] == "thermo")
    thermo["columns"]["ke"][-1] = None
    assert nan["state"] == "post_processed"
    records[1].write_text(json.dumps(nan))
    return records


@pytest.mark.parametrize("store", ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def test_both_stores_take_and_refuse_the_same_records(store, tmp_path, request):
    project = make_project(tmp_path)
    records = _records(project, tmp_path / "elsewhere")
    env = {}
    if store == "postgresql":
        env["HARNESS_DATABASE_URL"] = request.getfixturevalue("postgres_url")
    result = harness(project, "import", str(tmp_path / "elsewhere"), "--as-machine", "far", env=env)
    assert "Traceback" not in result.stderr
    assert result.returncode == 1
    problems = [line for line in result.stderr.splitlines() if line.startswith("harness: ")]
    assert len(problems) == 3, result.stderr
    assert any(f"{records[0]}: not a valid run record: $.failure_message: holds a NUL character" in p
               for p in problems), problems
    assert any(f"{records[2]}: not a valid run record: $.build.commit: 65 characters, more than the store holds"
               in p for p in problems), problems
    assert any(f"{records[1]}: $.series: non-finite (null) values in thermo.ke" in p for p in problems), problems
    assert "imported 2 runs; 3 problems" in result.stdout
    list_ = harness(project, "list", "--all-builds", "--json", "--machine", "far", env=env)
    runs = {(r["testcase"], r["run"]): r for r in json.loads(list_.stdout)}
    assert len(runs) == 2, runs
    long = json.loads(records[2].read_text())
    long["build"]["commit"] = "f" * 65  # longer than the store's commit column
    records[2].write_text(json.dumps(long))
    nan = json.loads(records[1].read_text())
    stored = runs[(nan["testcase"], nan["run"])]
    assert (stored["state"], stored["failure_reason"]) == ("failed", "non_finite"), stored


MALFORMED_URLS = ["postgres://x", "postgres://", "postgres:///", "postgresql://u@h:99999/db",
                  "postgresql://u@h:port/db", "postgresql://u@[::1/db", "mysql://a/b", "x", " ", "sqlite://",
                  "postgresql://u@127.0.0.1:1/db"]


@pytest.mark.parametrize("url", MALFORMED_URLS)
def test_every_malformed_database_url_is_one_line(url, tmp_path):
    project = make_project(tmp_path, cases=1)
    for command in (["list"], ["check"]):
        result = harness(project, *command, env={"HARNESS_DATABASE_URL": url})
        assert result.returncode == 1
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("harness: error: "), result.stderr
    assert not (project["home"] / "harness.sqlite3").exists()
