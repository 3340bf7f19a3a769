"""Are the engine's outputs byte-identical at two git revisions? Every run of testcases/ the engine can run.

    python benchmarks/engine_identical.py [--base main] [--new HEAD|worktree] [--only PATTERN] [-j 1]

Each revision's `engine/` is exported (git archive; `worktree` uses this working tree as it is) into a temporary
folder and every run of every test case under testcases/ whose script is an engine script (a `.json` file, or
the `dem` entry of a script map) is run with it: the test case's files copied into a fresh folder, the run's
variables (and each value of a sweep) on the command line, the `post/` folder of the run it depends on copied
in first, one thread. Then every file the two runs wrote is compared byte for byte - thermo and print files,
VTK dumps, restart files, the log - except the measured times: `timing.json` is skipped and the log's
`Loop time` lines are left out. Prints one line per run and the count of runs that differ; exit code 1 when
any does.
"""
from __future__ import annotations

import argparse
import fnmatch
import itertools
import json
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TIMED_FILES = {"timing.json"}


def export_engine(revision: str, into: Path) -> Path:
    """A folder holding `engine/` of revision ('worktree': this working tree)."""
    into.mkdir(parents=True)
    if revision == "worktree":
        shutil.copytree(REPO / "engine", into / "engine", ignore=shutil.ignore_patterns("__pycache__"))
        return into
    archive = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", revision, "engine"],
                             capture_output=True, check=True).stdout
    with tarfile.open(fileobj=__import__("io").BytesIO(archive)) as tar:
        tar.extractall(into)
    return into


def engine_script(entry: dict) -> str | None:
    script = entry.get("script")
    if isinstance(script, dict):
        script = script.get("dem")
    return script if isinstance(script, str) and script.endswith(".json") else None


def variable_sets(entry: dict) -> list[tuple[str, dict]]:
    """(suffix, variables) of each run of an entry: one, or one per value of its sweep."""
    variables = dict(entry.get("variables") or {})
    sweep = entry.get("sweep")
    if not sweep:
        return [("", variables)]
    runs = []
    for k, value in enumerate(sweep["values"]):
        extra = {name: values[k] for name, values in (sweep.get("with") or {}).items()}
        runs.append((f"[{sweep['variable']}={value}]", {**variables, sweep["variable"]: value, **extra}))
    return runs


def discover(pattern: str | None) -> list[dict]:
    """Every engine run of testcases/, dependencies before the runs that need them."""
    runs = []
    for config in sorted((REPO / "testcases").rglob("run.config")):
        folder = config.parent
        entries = json.loads(config.read_text()).get("runs", [])
        for entry in entries:
            script = engine_script(entry)
            if script is None:
                continue
            for suffix, variables in variable_sets(entry):
                name = f"{folder.relative_to(REPO / 'testcases')}/{entry['name']}{suffix}"
                if pattern and not fnmatch.fnmatch(name, pattern):
                    continue
                runs.append(dict(name=name, folder=folder, script=script, variables=variables,
                                 depends_on=f"{folder.relative_to(REPO / 'testcases')}/{entry['depends_on']}"
                                 if entry.get("depends_on") else None))
    return runs


def in_dependency_order(runs: list[dict]) -> list[list[dict]]:
    """Batches of runs: those that depend on nothing, then those whose dependency ran in an earlier batch..."""
    depth = {}

    def level(run):
        if run["name"] not in depth:
            parent = next((r for r in runs if r["name"] == run["depends_on"]), None)
            depth[run["name"]] = 0 if parent is None else level(parent) + 1
        return depth[run["name"]]
    batches: dict = {}
    for run in runs:
        batches.setdefault(level(run), []).append(run)
    return [batches[k] for k in sorted(batches)]


def run_one(run: dict, engine_root: Path, workdir: Path, timeout: float) -> Path:
    folder = workdir / run["name"].replace("/", "__")
    shutil.copytree(run["folder"], folder)
    (folder / "post").mkdir(exist_ok=True)
    if run["depends_on"]:
        shutil.copytree(workdir / run["depends_on"].replace("/", "__") / "post", folder / "post", dirs_exist_ok=True)
    command = [sys.executable, "-m", "engine", "-in", run["script"], "-log", "log.dem", "-threads", "1"]
    for name, value in run["variables"].items():
        command += ["-var", str(name), str(value)]
    env = {**os.environ, "PYTHONPATH": str(engine_root), "NUMBA_NUM_THREADS": "1"}
    with open(folder / "stdout.txt", "wb") as out:
        subprocess.run(command, cwd=folder, env=env, stdout=out, stderr=subprocess.STDOUT, timeout=timeout)
    return folder


def comparable(path: Path) -> bytes:
    data = path.read_bytes()
    if path.name in ("log.dem", "stdout.txt"):
        data = b"".join(line for line in data.splitlines(keepends=True) if not line.startswith(b"Loop time of "))
    return data


def differences(a: Path, b: Path) -> list[str]:
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    problems = [f"only in one: {p}" for p in sorted(files_a ^ files_b)]
    for rel in sorted(files_a & files_b):
        if rel.name in TIMED_FILES:
            continue
        if comparable(a / rel) != comparable(b / rel):
            problems.append(f"differs: {rel}")
    return problems


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main")
    parser.add_argument("--new", default="HEAD", help="a revision, or 'worktree'")
    parser.add_argument("--only", help="glob over 'testcase/run' names, e.g. 'walls/*'")
    parser.add_argument("-j", type=int, default=1, help="runs at a time")
    parser.add_argument("--timeout", type=float, default=3600.0)
    parser.add_argument("--keep", help="keep the run folders in this folder")
    args = parser.parse_args(argv)
    runs = discover(args.only)
    with tempfile.TemporaryDirectory(prefix="engine_identical_") as tmp:
        root = Path(args.keep) if args.keep else Path(tmp)
        engines = {side: export_engine(rev, root / f"engine_{side}") for side, rev in
                   (("base", args.base), ("new", args.new))}
        bad = 0
        for side in ("base", "new"):
            (root / side).mkdir()
        for batch in in_dependency_order(runs):
            jobs = list(itertools.product(batch, ("base", "new")))
            with ThreadPoolExecutor(args.j) as pool:
                list(pool.map(lambda job: run_one(job[0], engines[job[1]], root / job[1], args.timeout), jobs))
            for run in batch:
                name = run["name"].replace("/", "__")
                problems = differences(root / "base" / name, root / "new" / name)
                bad += bool(problems)
                print(f"{'DIFFERS  ' if problems else 'identical'} {run['name']}" +
                      "".join(f"\n    {p}" for p in problems[:10]), flush=True)
        print(f"{len(runs)} runs, {bad} differ ({args.base} vs {args.new})")
        return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
