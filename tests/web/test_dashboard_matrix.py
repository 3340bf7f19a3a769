"""The cross-code matrix page (/matrix/) shows what `harness matrix` computes on the same store.

The real CLI runs a fake engine at three revisions as three targets named ``*-crosscode`` (the matrix's
default targets) in a throw-away workspace and writes ``harness matrix --json``; the real dashboard
(`python manage.py runserver` on that workspace) must give the same JSON and show each cell's C as the CLI
prints it, linking to the comparison of the two runs.
"""
from __future__ import annotations

import html as htmllib
import json
import os
import re
import sqlite3
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from harness_process import free_port, stop_session

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "harness"))

import harness_process  # noqa: E402
from harness_support import commit_files, fake_engine_source, git_repo  # noqa: E402

SCENE = [{"command": "create", "heights": [1.0, 0.5]}, {"command": "run", "steps": 200, "every": 20}]
#: gravity of each target's engine: b differs by 1e-5 (consistent), c by 30 % (not)
GRAVITY = {"a-crosscode": 9.81, "b-crosscode": 9.81 * (1 + 1e-5), "c-crosscode": 9.81 * 1.3}


def env(home: Path) -> dict:
    out = {k: v for k, v in os.environ.items()
           if k not in ("DJANGO_SETTINGS_MODULE", "HARNESS_DATABASE_URL", "HARNESS_DEBUG", "HARNESS_HOME")}
    out.update({"HARNESS_HOME": str(home), "PYTHONPATH": str(REPO)})
    return out


def harness(home: Path, targets: Path, *args: str) -> subprocess.CompletedProcess:
    return harness_process.harness(home, *args, targets=targets, machine="matrixbox", env=env(home))


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """Three targets' runs of two test cases, and `harness matrix --json`; (home, CLI JSON, CLI stdout)."""
    root = tmp_path_factory.mktemp("matrix")
    repo = git_repo(root / "repo")
    cases = {}
    for case in ("cases/drop", "cases/pair"):
        cases[f"{case}/scene.json"] = json.dumps(SCENE)
        cases[f"{case}/run.config"] = json.dumps({"runs": [{"name": "main", "script": "scene.json"}]})
    commits = {}
    for name, gravity in GRAVITY.items():
        commits[name] = commit_files(repo, {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(gravity),
                                            **cases}, name)
    targets = root / "targets"
    targets.mkdir()
    for name, commit in commits.items():
        (targets / f"{name}.json").write_text(json.dumps({
            "repository": str(root / "repo"), "revision": commit, "testcases_revision": commits["a-crosscode"],
            "testcases": ["cases"]}))
    home = root / "home"
    harness(home, targets, "run", *GRAVITY)
    out = root / "matrix.json"
    printed = harness(home, targets, "matrix", "--json", str(out)).stdout
    return home, json.loads(out.read_text()), printed


@pytest.fixture(scope="module")
def server(workspace):
    home = workspace[0]
    port = free_port()
    log = home / "server.log"
    process = subprocess.Popen([sys.executable, "manage.py", "runserver", "--noreload", f"127.0.0.1:{port}"],
                               cwd=REPO, env={**env(home), "DJANGO_SETTINGS_MODULE": "webfrontend.settings"},
                               stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True)

    def get(path: str) -> tuple[int, str]:
        deadline = time.monotonic() + 90
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=60) as response:
                    return response.status, response.read().decode()
            except urllib.error.HTTPError as error:
                return error.code, error.read().decode()
            except OSError:
                assert process.poll() is None, log.read_text()
                assert time.monotonic() < deadline, log.read_text()
                time.sleep(0.3)

    yield get
    stop_session(process)


def test_the_dashboard_gives_the_json_harness_matrix_writes(workspace, server):
    _, cli, _ = workspace
    assert len(cli["cells"]) == 2 * 6 * 3 and cli["problems"] == []  # 2 runs, 6 ordered pairs, ke rke atoms
    status, body = server("/matrix.json")
    assert status == 200
    assert json.loads(body) == cli
    levels = {(c["code"], c["reference"], c["quantity"]): c["level"] for c in cli["cells"]}
    assert levels[("b-crosscode", "a-crosscode", "ke")] == "perfect"
    assert levels[("c-crosscode", "a-crosscode", "ke")] == "inconsistent"


def test_the_page_shows_every_cell_as_the_cli_prints_it_linking_to_the_two_runs(workspace, server):
    from harness.analysis.matrix import _c, _short

    home, cli, printed = workspace
    status, page = server("/matrix/")
    assert status == 200
    page = htmllib.unescape(page)
    with sqlite3.connect(home / "harness.sqlite3") as db:
        ids = {(t, path): pk for t, path, pk in db.execute(
            "SELECT t.name, c.path, r.id FROM harness_run r JOIN harness_target t ON r.target_id = t.id "
            "JOIN harness_testcase c ON r.testcase_id = c.id")}
    tables = {}
    for title, table in re.findall(r'<h3 class="matrix-title">([^<]+)</h3>\s*<div class="scroll">(.*?)</table>',
                                   page, re.S):
        rows = {}
        for row in re.findall(r"<tr><th>(.*?)</tr>", table, re.S):
            code = re.sub(r"<[^>]+>", "", row.split("</th>", 1)[0]).strip()
            rows[code] = re.findall(r'<td class="num matrix-cell"[^>]*><a class="level (\w+)" href="([^"]+)">'
                                    r"([^<]+)</a>", row)
        tables[title.strip()] = rows
    # the CLI's text tables: the same blocks (the particle count only where it differs)
    printed_titles = {line.split("  ")[0].strip() for line in printed.splitlines() if line.startswith("cases/")}
    assert set(tables) == printed_titles and len(tables) == 2 * 2  # ke and rke of two test case runs
    shown = 0
    for cell in cli["cells"]:
        title = f"{cell['testcase']}/{cell['run']} {cell['quantity']}"
        if title not in tables:
            continue
        others = [c for c in GRAVITY if c != cell["code"]]
        level, url, text = tables[title][cell["code"]][others.index(cell["reference"])]
        assert (level, text) == (cell["level"], f"{_c(cell['value'])} {_short(cell['level'])}"), (title, cell)
        reference_run, code_run = ids[(cell["reference"], cell["testcase"])], ids[(cell["code"], cell["testcase"])]
        assert url == f"/compare/?run={reference_run}%2C{code_run}"
        shown += 1
    assert shown == 2 * 2 * 6
    # the lowest C per pair, as the CLI's summary
    for line in printed.split("lowest C per pair (code | reference):")[1].splitlines():
        match = re.match(r"\s+(\S+) \| (\S+): (\S+) (\w+) \((.+)\)$", line)
        if match:
            code, reference, value, level, where = match.groups()
            assert re.search(rf"<td>{code}</td><td>{reference}</td><td class=\"num\"><span class=\"level {level}\">"
                             rf"{re.escape(value)} {level}</span></td><td>{re.escape(where)}</td>", page), line
    # a cell's link opens the two runs' comparison
    first = next(iter(tables.values()))["b-crosscode"][0][1]
    status, compare = server(first)
    assert status == 200 and "Comparison of 2 runs" in compare


def test_targets_and_pattern_are_kept_in_the_json_link(workspace, server):
    home = workspace[0]
    with sqlite3.connect(home / "harness.sqlite3") as db:
        ids = dict(db.execute("SELECT name, id FROM harness_target"))
    status, page = server(f"/matrix/?target={ids['c-crosscode']}&target={ids['a-crosscode']}&k=drop")
    assert status == 200
    page = htmllib.unescape(page)
    assert "cases/drop/main ke" in page and "cases/pair/main" not in page
    link = re.search(r'<a href="(/matrix\.json\?[^"]+)">JSON</a>', page).group(1)
    status, body = server(link)
    data = json.loads(body)
    assert data["targets"] == ["c-crosscode", "a-crosscode"]
    assert {(c["code"], c["testcase"]) for c in data["cells"]} == {("c-crosscode", "cases/drop"),
                                                                   ("a-crosscode", "cases/drop")}
