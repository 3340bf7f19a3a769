"""The store on a real PostgreSQL server (Debian's postgresql, started into a temporary folder): the CLI,
two harness processes acting as two machines writing at once, and the store, CLI and dashboard suites."""
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from pg_server import Server, binaries

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.postgres

if binaries() is None:
    pytest.skip("Debian's postgresql server is not installed (scripts/setup.sh installs it)",
                allow_module_level=True)


def _support():
    spec = importlib.util.spec_from_file_location("provenance_support_pg",
                                                  ROOT / "tests" / "reliability" / "provenance_support.py")
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(ROOT / "tests" / "reliability"))
    spec.loader.exec_module(module)
    return module


support = _support()


@pytest.fixture(scope="module")
def server():
    # a folder of its own, not pytest's numbered temporary folders, which other pytest runs prune
    folder = Path(tempfile.mkdtemp(prefix="harness-postgres-"))
    pg = Server(folder / "server").start()
    yield pg
    pg.stop()
    shutil.rmtree(folder, ignore_errors=True)


def _rows(url: str, sql: str):
    """Rows straight from the server with psycopg (independent of Django)."""
    import dj_database_url
    import psycopg

    config = dj_database_url.parse(url)
    with psycopg.connect(dbname=config["NAME"], user=config["USER"], host=config["OPTIONS"]["host"]) as connection:
        return connection.execute(sql).fetchall()


def test_cli_runs_and_checks_on_a_postgres_store(server, tmp_path):
    url = server.create_database("harness_cli")
    project = support.make_project(tmp_path)
    env = {"HARNESS_DATABASE_URL": url}
    run = support.harness(project, "run", "dev", "-j", "2", env=env)
    assert run.returncode == 0, run.stdout + run.stderr
    check = support.harness(project, "check", "dev", env=env)
    assert check.returncode == 0 and "4 runs: 4 passed" in check.stdout
    assert _rows(url, "SELECT COUNT(*) FROM harness_run") == [(8,)]
    # nothing went to an SQLite file in the workspace
    assert not (project["home"] / "harness.sqlite3").exists()


def test_two_machines_write_one_postgres_store_at_once(server, tmp_path):
    url = server.create_database("harness_two")
    project = support.make_project(tmp_path, cases=3, sleep=0.2)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "HARNESS_DATABASE_URL": url}
    commands = [support.harness_command({**project, "home": tmp_path / f"home-{m}"}, "run", "dev", "-j", "2",
                                        machine=m) for m in ("alpha", "beta")]
    processes = [subprocess.Popen(c, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                 for c in commands]
    for process in processes:
        out, err = process.communicate(timeout=300)
        assert process.returncode == 0, out + err
    stored = _rows(url, """SELECT m.name, COUNT(*), COUNT(DISTINCT r.folder) FROM harness_run r
                           JOIN harness_machine m ON r.machine_id = m.id GROUP BY m.name ORDER BY m.name""")
    assert stored == [("alpha", 12, 12), ("beta", 12, 12)]
    assert _rows(url, "SELECT COUNT(*) FROM harness_testcase") == [(3,)]  # created once, though raced for


@pytest.mark.slow   # minutes: these suites run on SQLite in the default run already
def test_store_cli_and_dashboard_suites_pass_on_postgres(server, tmp_path):
    url = server.create_database("harness_suites")
    env = {**os.environ, "HARNESS_DATABASE_URL": url}
    env.pop("HARNESS_HOME", None)
    # its own --basetemp: pytest prunes older numbered temporary folders, this server's among them
    result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider",
                             "--basetemp", str(tmp_path / "inner"), "tests/harness", "tests/web", "-m", "not browser"],
                            cwd=ROOT, env=env, capture_output=True, text=True, timeout=1200)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert " passed" in result.stdout.splitlines()[-1]
