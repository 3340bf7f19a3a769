"""A project for the provenance and concurrency tests: a git repository holding the fake engine of
tests/harness at two revisions, test cases, and targets; the harness is always run as a real process."""
from __future__ import annotations

import importlib.util
import json
import sqlite3
import subprocess
from pathlib import Path

import harness_process
from harness_process import PROJECT as ROOT
from harness_process import commit_files, git_repo, project_env  # noqa: F401  (the reliability tests import them from here)


# the fake engine's source (tests/harness/harness_support.py), loaded by path: that folder is not on the path
_spec = importlib.util.spec_from_file_location("harness_support_for_reliability",
                                               ROOT / "tests" / "harness" / "harness_support.py")
_support = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_support)
fake_engine_source = _support.fake_engine_source


def scene(height: float = 1.0, steps: int = 200, sleep: float = 0.0) -> str:
    commands = [{"command": "create", "heights": [height, 0.5]}]
    if sleep:
        commands.append({"command": "sleep", "seconds": sleep})
    commands.append({"command": "run", "steps": steps, "every": 20})
    return json.dumps(commands)


def make_project(root: Path, cases: int = 2, sleep: float = 0.0) -> dict:
    """Repository with revisions ``v1`` (g = 9.81) and ``v2`` (g = 9.81 * 1.3, inconsistent), ``cases``
    test cases of two runs each, and targets ``ref`` (v1) and ``dev`` (revision in ``dev.json``,
    reference ``ref``). Test cases are read from the working tree."""
    repo = git_repo(root / "repo")
    files = {"engine/__init__.py": "", "engine/__main__.py": fake_engine_source(9.81)}
    for i in range(cases):
        files[f"cases/c{i}/scene.json"] = scene(1.0 + 0.1 * i, sleep=sleep)
        files[f"cases/c{i}/run.config"] = json.dumps({"runs": [
            {"name": "a", "script": "scene.json"}, {"name": "b", "script": "scene.json", "variables": {"X": 1}}]})
    v1 = commit_files(repo, files, "v1", tag="v1")
    v2 = commit_files(repo, {"engine/__main__.py": fake_engine_source(9.81 * 1.3)}, "v2: gravity 30 % larger",
                      tag="v2")
    targets = root / "targets"
    targets.mkdir()
    write_target(targets, "ref", revision="v1", repo=repo)
    write_target(targets, "dev", revision="v1", repo=repo, reference="ref")
    return {"repo": repo, "root": Path(repo.working_tree_dir), "targets": targets, "home": root / "home",
            "v1": v1, "v2": v2}


def write_target(targets: Path, name: str, revision: str, repo, reference: str | None = None) -> None:
    definition = {"repository": str(repo.working_tree_dir), "revision": revision, "testcases": ["cases"],
                  "testcases_revision": "working-tree"}
    if reference:
        definition["reference"] = reference
    (targets / f"{name}.json").write_text(json.dumps(definition))


def harness_command(project: dict, *args: str, machine: str = "m1") -> list[str]:
    return harness_process.command(project["home"], *args, targets=project["targets"], machine=machine)


def harness(project: dict, *args: str, machine: str = "m1", timeout: float = 300, env: dict | None = None
            ) -> subprocess.CompletedProcess:
    """``harness ARGS`` on the project's store as ``machine`` (the exit code is the caller's to check)."""
    return harness_process.harness(project["home"], *args, targets=project["targets"], machine=machine,
                                   check=False, timeout=timeout, env=project_env(**(env or {})))


def rows(project: dict, sql: str, *params) -> list[tuple]:
    """Rows of the project's SQLite store, read with the standard library (independent of Django)."""
    with sqlite3.connect(project["home"] / "harness.sqlite3") as connection:
        return connection.execute(sql, params).fetchall()


RUNS = """SELECT t.name, tc.path, r.name, r.testcase_hash, b."commit", r.state, r.folder, r.replaced
          FROM harness_run r JOIN harness_target t ON r.target_id = t.id
          JOIN harness_testcase tc ON r.testcase_id = tc.id JOIN harness_build b ON r.build_id = b.id"""
