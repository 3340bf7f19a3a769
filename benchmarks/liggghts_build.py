"""Cold and incremental builds of LIGGGHTS-PUBLIC from source (target liggghts-src, issue 19).

Builds the target ``liggghts-src`` (CMake, Release, no VTK, ccache) through the harness CLI in a fresh
workspace with an empty ccache folder: first COLD (default ``HEAD~3``), then NEXT (default ``HEAD~2``, the
adjacent commit, which changes one source file). Prints each build's time (the harness' own measurement:
export, patches, configure, compile, link), ccache's hits and misses, and the ratio NEXT / COLD. Both builds
run in this one invocation, one after the other, so they see the same machine load.

    python benchmarks/liggghts_build.py                         # HEAD~3 cold, then HEAD~2
    python benchmarks/liggghts_build.py --cold 3.7.0 --next 3.8.0 -j 2
"""
from __future__ import annotations

import argparse
import json
import os
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def build(home: Path, ccache: Path, revision: str, jobs: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "HARNESS_CCACHE_DIR": str(ccache)}
    env.pop("HARNESS_HOME", None)
    result = subprocess.run([sys.executable, "-m", "harness.cli", "--home", str(home), "build",
                             f"liggghts-src@{revision}", "-j", str(jobs)], cwd=ROOT, env=env,
                            capture_output=True, text=True)
    if result.returncode != 0:
        raise SystemExit(f"build of liggghts-src@{revision} failed:\n{result.stderr[-3000:]}")
    with sqlite3.connect(home / "harness.sqlite3") as db:
        commit, details = db.execute("SELECT \"commit\", details FROM harness_build ORDER BY id DESC LIMIT 1"
                                     ).fetchone()
    return {"revision": revision, "commit": commit, **json.loads(details)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cold", default="HEAD~3", help="revision built first, with an empty ccache")
    parser.add_argument("--next", default="HEAD~2", help="revision built second, through the warm ccache")
    parser.add_argument("-j", dest="jobs", type=int, default=os.cpu_count() or 1, help="compile jobs")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="liggghts-build-") as scratch:
        home, ccache = Path(scratch) / "home", Path(scratch) / "ccache"
        rows = [build(home, ccache, revision, args.jobs) for revision in (args.cold, args.next)]
    print(f"{'build':<6} {'revision':<10} {'commit':<12} {'seconds':>8} {'hits':>6} {'misses':>6}  patches")
    for label, row in zip(("cold", "next"), rows):
        stats = row.get("ccache_stats", {})
        hits = stats.get("direct_cache_hit", 0) + stats.get("preprocessed_cache_hit", 0)
        print(f"{label:<6} {row['revision']:<10} {row['commit'][:12]:<12} {row['duration_s']:>8.1f} {hits:>6} "
              f"{stats.get('cache_miss', 0):>6}  {', '.join(row.get('patches', [])) or '-'}")
    print(f"next / cold = {rows[1]['duration_s'] / rows[0]['duration_s']:.3f} (jobs {args.jobs}, "
          f"load average {os.getloadavg()[0]:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
