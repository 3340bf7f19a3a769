"""What a bisect over engine commits pays in compilation: 8 commits built and run one after the other.

A bisect (``harness bisect``) exports ``engine/`` at each commit it tries into a new build folder and runs it;
every build shares the kernel cache ($DEM_CACHE_DIR). This benchmark makes the equivalent builds: in a
temporary clone at BASE it commits 8 typical engine changes one after the other (docstrings, comments, a
module without compiled code, the README, an unused new function, one real change of the Hertz law), then
for BASE and each commit exports ``engine/`` with ``git archive`` into a fresh folder (no __pycache__) and
runs the settling scene (engine/examples/settling.json, N spheres, one thread, a few steps) with one shared
cache, warmed by BASE. Printed per commit: wall time of the process, the engine's `compile` (timing.json), and
the compiled functions written to the cache (NUMBA_DEBUG_CACHE "data saved"); then the totals over the 8.

    python benchmarks/engine_rebuilds.py HEAD          # this branch
    python benchmarks/engine_rebuilds.py 5c2e077       # an engine before the content-keyed cache
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

UNUSED_FUNCTION = '''

@njit(cache=True, error_model="numpy")
def unused_helper(x):
    """A function no kernel calls."""
    return 2.0 * x
'''

#: (message, file under engine/, old text, new text): each applied to the previous commit
EDITS = [
    ("neighbor: docstring", "neighbor.py", '"""Rebuild the neighbor list', '"""Rebuilds the neighbor list'),
    ("kernels: module docstring", "kernels.py", '"""Kernel builder:', '"""The kernel builder:'),
    ("contact laws: a comment", "contact_laws.py", "    sqrt_rd = sqrt(reff * overlap)\n",
     "    sqrt_rd = sqrt(reff * overlap)  # m\n"),
    ("commands: docstring", "commands.py", '"""', '"""Changed. '),
    ("README", "README.md", "# The bundled DEM engine", "# The bundled DEM engine (Numba)"),
    ("mesh: a comment", "mesh.py", "\nimport numpy as np\n", "\nimport numpy as np  # arrays\n"),
    ("contact laws: a new function no kernel calls", "contact_laws.py", None, UNUSED_FUNCTION),
    ("contact laws: Hertz law rewritten (same values)", "contact_laws.py", "sn = 2.0 * ystar * sqrt_rd",
     "sn = ystar * sqrt_rd * 2.0"),
]


def git(*args, cwd):
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True, text=True).stdout.strip()


def make_commits(clone: Path) -> list[tuple[str, str]]:
    """[(label, commit)]: BASE, then one commit per edit."""
    commits = [("BASE", git("rev-parse", "HEAD", cwd=clone))]
    for message, name, old, new in EDITS:
        path = clone / "engine" / name
        text = path.read_text()
        if old is None:
            text += new
        else:
            if old not in text:
                raise SystemExit(f"edit '{message}': {old!r} not in engine/{name} at BASE")
            text = text.replace(old, new, 1)
        path.write_text(text)
        git("commit", "-qam", message, cwd=clone)
        commits.append((message, git("rev-parse", "HEAD", cwd=clone)))
    return commits


def build_and_run(clone: Path, commit: str, folder: Path, cache: Path, n: int, steps: int):
    """(wall s, compile s, functions compiled) of one build's settling run."""
    src = folder / "src"
    src.mkdir(parents=True)
    archive = subprocess.run(["git", "archive", commit, "engine"], cwd=clone, check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive.stdout, check=True)
    run = folder / "run"
    run.mkdir()
    env = dict(os.environ, PYTHONPATH=str(src), DEM_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="1",
               NUMBA_DEBUG_CACHE="1")
    variables = dict(N=n, SEED=1, HALF_WIDTH=0.02, HEIGHT=0.1, DUMP_EVERY=10 ** 9, SETTLE_STEPS=steps,
                     MEASURE_STEPS=steps)
    cmd = [sys.executable, "-m", "engine", "-in", str(src / "engine" / "examples" / "settling.json"), "-log",
           "log.dem"] + [a for k, v in variables.items() for a in ("-var", k, str(v))]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=run, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode:
        raise SystemExit(f"engine at {commit[:10]} failed: {proc.stderr.strip()[-300:]}")
    compiled = len(re.findall(r"data saved to", proc.stdout + proc.stderr))
    return wall, json.loads((run / "timing.json").read_text())["compile"], compiled


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("base", help="the commit the 8 changes are made on (e.g. HEAD)")
    parser.add_argument("--particles", type=int, default=2000)
    parser.add_argument("--steps", type=int, default=100, help="steps of each of the scene's two runs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        clone = tmp / "clone"
        subprocess.run(["git", "clone", "-q", "--no-checkout", str(REPO), str(clone)], check=True)
        git("checkout", "-q", git("rev-parse", args.base, cwd=REPO), cwd=clone)
        git("config", "user.email", "bench@localhost", cwd=clone)
        git("config", "user.name", "bench", cwd=clone)
        commits = make_commits(clone)
        print(f"base {commits[0][1][:10]} ({args.base}); settling scene, {args.particles} spheres, "
              f"2 x {args.steps} steps, 1 thread, one shared cache")
        print(f"{'commit':<50} {'wall (s)':>9} {'compile (s)':>11} {'compiled':>9}")
        total_wall = total_compile = 0.0
        total_compiled = 0
        for index, (label, commit) in enumerate(commits):
            wall, compile_time, compiled = build_and_run(clone, commit, tmp / f"build{index}", tmp / "cache",
                                                         args.particles, args.steps)
            print(f"{label:<50} {wall:>9.1f} {compile_time:>11.1f} {compiled:>9d}", flush=True)
            if index:
                total_wall += wall
                total_compile += compile_time
                total_compiled += compiled
        print(f"{'8 commits after BASE':<50} {total_wall:>9.1f} {total_compile:>11.1f} {total_compiled:>9d}")


if __name__ == "__main__":
    main()
