"""Cold and incremental builds of LIGGGHTS-PUBLIC from source (target liggghts-src).

Builds the target ``liggghts-src`` (CMake, Release, VTK, ccache) through the harness CLI with one ccache
folder, empty at the start: first COLD (default ``HEAD~3``) in a fresh workspace; then (``--warm``) the same
revision again in a second fresh workspace, through the now warm ccache (what a CI machine with a kept cache
does); then NEXT (default ``HEAD~2``, the adjacent commit, which changes one source file: a bisect step) in
the first workspace. Prints each build's time (the harness' own measurement: export, patches, configure,
compile, link), ccache's hits and misses, the ratios to COLD and the load average. The builds run in this one
invocation, one after the other, so they see about the same machine load.

    python benchmarks/liggghts_build.py -j 2                    # HEAD~3 cold, HEAD~2
    python benchmarks/liggghts_build.py -j 2 --warm             # HEAD~3 cold, HEAD~3 warm, HEAD~2
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
    parser.add_argument("--warm", action="store_true",
                        help="also build COLD again in a fresh workspace through the warm ccache")
    parser.add_argument("-j", dest="jobs", type=int, default=os.cpu_count() or 1, help="compile jobs")
    args = parser.parse_args(argv)
    loads = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory(prefix="liggghts-build-") as scratch:
        home, ccache = Path(scratch) / "home", Path(scratch) / "ccache"
        plan = [("cold", home, args.cold)] + ([("warm", Path(scratch) / "home2", args.cold)] if args.warm else []) \
            + [("next", home, args.next)]
        rows = []
        for label, workspace, revision in plan:
            rows.append((label, build(workspace, ccache, revision, args.jobs)))
            loads.append(os.getloadavg()[0])
    cold = rows[0][1]["duration_s"]
    print(f"{'build':<6} {'revision':<10} {'commit':<12} {'seconds':>8} {'/cold':>6} {'hits':>6} {'misses':>6}  "
          f"patches")
    for label, row in rows:
        stats = row.get("ccache_stats", {})
        hits = stats.get("direct_cache_hit", 0) + stats.get("preprocessed_cache_hit", 0)
        print(f"{label:<6} {row['revision']:<10} {row['commit'][:12]:<12} {row['duration_s']:>8.1f} "
              f"{row['duration_s'] / cold:>6.3f} {hits:>6} {stats.get('cache_miss', 0):>6}  "
              f"{', '.join(row.get('patches', [])) or '-'}")
    print(f"jobs {args.jobs}; load average (1 min) at the start and after each build: "
          + " ".join(f"{load:.1f}" for load in loads))
    return 0


if __name__ == "__main__":
    sys.exit(main())
