"""Two builds of the bundled engine side by side on the test case collection: same bytes? how fast?

Each dem run of testcases/ (sweeps expanded, `depends_on` chains run in one folder) is run with engine A and
engine B (each an `engine/` folder, e.g. an old commit exported with `git archive <commit> engine | tar -x -C
/tmp/old`), alternating A and B so that the machine's load hits both alike. Reported per run: whether every
output file (thermo.csv, print files, VTK dumps) is byte-identical, the first differing file otherwise, and
the loop-time ratio B/A (timing.json `total`: stepping time without start-up or JIT compilation).

    python benchmarks/engine_versions.py /tmp/old .                 # old export against this checkout
    python benchmarks/engine_versions.py /tmp/old . -k settling      # runs whose name contains 'settling'
    python benchmarks/engine_versions.py . . --threads-b 2           # this build, 1 thread against 2 threads

Exit code 1 when some run differs (or fails in one build only).
"""
from __future__ import annotations

import argparse
import filecmp
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def dem_runs(root: Path, match: str | None):
    """(label, folder, [(script, variables), ...]) per run of the bundled engine; a chain runs in one folder."""
    for config in sorted(root.glob("**/run.config")):
        folder = config.parent
        data = json.loads(config.read_text())
        chains: dict[str, list] = {}
        for run in data.get("runs", []):
            script = run.get("script")
            if isinstance(script, dict):
                script = script.get("dem")
            if not isinstance(script, str) or not script.endswith(".json"):
                continue
            variables = dict(run.get("variables", {}))
            sweep = run.get("sweep")
            if sweep:
                for k, value in enumerate(sweep["values"]):
                    v = dict(variables, **{sweep["variable"]: value})
                    v.update({name: values[k] for name, values in sweep.get("with", {}).items()})
                    chains[f"{run['name']}={value}"] = [(script, v)]
            elif run.get("depends_on") in chains:
                chains[run["depends_on"]].append((script, variables))
            else:
                chains[run["name"]] = [(script, variables)]
        for name, steps in chains.items():
            label = f"{folder.relative_to(root)}/{name}"
            if match is None or match in label:
                yield label, folder, steps


def run_chain(engine_dir: Path, case: Path, steps, work: Path, threads: int | None) -> tuple[int, float, str]:
    """Run the chain in a copy of the test case folder; (exit code, loop seconds, stderr tail)."""
    shutil.copytree(case, work)
    env = dict(os.environ, PYTHONPATH=str(engine_dir.resolve()))
    if threads is not None:
        env["NUMBA_NUM_THREADS"] = str(threads)
    loop = 0.0
    for k, (script, variables) in enumerate(steps):
        args = [a for name, value in variables.items() for a in ("-var", name, str(value))]
        proc = subprocess.run([sys.executable, "-m", "engine", "-in", script, "-log", f"log{k}.dem", *args],
                              cwd=work, env=env, capture_output=True, text=True)
        timing = work / "timing.json"
        if timing.exists():
            loop += json.loads(timing.read_text()).get("total", 0.0)
            timing.rename(work / f"timing{k}.json")
        if proc.returncode:
            return proc.returncode, loop, proc.stderr.strip()[-300:]
    return 0, loop, ""


#: files that differ between builds by design: logs (timings), the timing record, restart files (the engine's
#: own binary format; what a chained run continues from them is compared)
VOLATILE = ("log", "timing")


def compare_folders(a: Path, b: Path) -> str | None:
    """The first output file that differs (or exists in one folder only), None when all are identical."""
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    for rel in sorted(files_a | files_b):
        if rel.name.startswith(VOLATILE) or rel.suffix in (".restart", ".npz"):
            continue
        if rel not in files_a or rel not in files_b:
            return f"{rel} (only in {'B' if rel not in files_a else 'A'})"
        if not filecmp.cmp(a / rel, b / rel, shallow=False):
            return str(rel)
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("engine_a", type=Path, help="folder holding engine/ (build A)")
    parser.add_argument("engine_b", type=Path, help="folder holding engine/ (build B)")
    parser.add_argument("-k", dest="match", help="only runs whose label contains this text")
    parser.add_argument("--testcases", type=Path, default=REPO / "testcases")
    parser.add_argument("--threads-a", type=int, help="NUMBA_NUM_THREADS for build A")
    parser.add_argument("--threads-b", type=int, help="NUMBA_NUM_THREADS for build B")
    args = parser.parse_args()
    differing = 0
    total_a = total_b = 0.0
    print(f"{'run':<58} {'bytes':<10} {'loop A (s)':>10} {'loop B (s)':>10} {'B/A':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for index, (label, case, steps) in enumerate(dem_runs(args.testcases, args.match)):
            work = Path(tmp) / str(index)
            code_a, loop_a, err_a = run_chain(args.engine_a, case, steps, work / "a", args.threads_a)
            code_b, loop_b, err_b = run_chain(args.engine_b, case, steps, work / "b", args.threads_b)
            if code_a or code_b:
                verdict = "same exit" if code_a == code_b else "FAILED"
                detail = f" A:{code_a} {err_a} B:{code_b} {err_b}"
                differing += code_a != code_b
            else:
                first = compare_folders(work / "a", work / "b")
                verdict = "identical" if first is None else "DIFFER"
                detail = "" if first is None else f" first: {first}"
                differing += first is not None
            total_a += loop_a
            total_b += loop_b
            ratio = loop_b / loop_a if loop_a > 0 else float("nan")
            print(f"{label:<58} {verdict:<10} {loop_a:>10.3f} {loop_b:>10.3f} {ratio:>6.2f}{detail}", flush=True)
            shutil.rmtree(work, ignore_errors=True)
    print(f"total loop time A {total_a:.2f} s, B {total_b:.2f} s, B/A {total_b / max(total_a, 1e-12):.3f}; "
          f"{differing} run(s) differ")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
