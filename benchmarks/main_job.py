"""The main job (scripts/main.sh) from an empty workspace and an empty kernel cache, stage by stage, then the
collection again with the cache warm: the figures of the goals "the whole collection with an empty cache <= 2x
its warm time" and "the main job on a fresh machine in <= 8 minutes".

The revision is cloned into a temporary folder; HARNESS_HOME and DEM_CACHE_DIR point to empty folders in it, so
nothing of yours is read or written. The Python packages count as installed (a marker in the clone keeps
setup.sh from running pip there, which would point your editable install at the clone): the setup stage is
setup.sh finding everything in place. Stages: setup, `harness build`, `harness run -j N` (cold: every kernel
compiled), `harness check --junit`; then `harness run -j N --all` (warm: the same runs, the kernels cached).
From the run records: per target the runs, their wall and compile seconds; the core-seconds the run stage left
idle (N x its span - the runs' wall time) and its last minute's share of it; the start-up of a warm 1-particle
engine run.

    python benchmarks/main_job.py                     # HEAD, -j 2
    python benchmarks/main_job.py --rev main -j 2
    python benchmarks/main_job.py --analyze /tmp/home # the breakdown of a workspace that ran the job
    python benchmarks/main_job.py --install           # what a fresh machine downloads (apt-get -s, no download)
    python benchmarks/main_job.py --install --pip     # and pip's time in a new virtual environment
    python benchmarks/main_job.py --write-times /tmp/home  # ship that workspace's wall times (see below)

--write-times writes the wall times of a workspace's runs (after this benchmark, those of the warm pass) into
harness/execution/expected_times.json: the figures the scheduler starts the long runs first by on a machine
whose workspace has no record of them yet (harness/execution/expected.py).

--install estimates the Debian part of a fresh machine's installation without installing anything: apt-get
simulates the installation of setup.sh's packages on a minimal Debian (the packages of priority required and
important and what they depend on, taken from this machine's dpkg status), and the packages' sizes are summed.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from datetime import datetime
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def stage(name: str, command: list[str], cwd: Path, env: dict, log: Path) -> float:
    """Wall seconds of one stage (its output to log; a non-zero exit is reported, not fatal: a check that
    finds inconsistencies exits 1 and still counts as the stage's time)."""
    t0 = time.perf_counter()
    with open(log, "w") as out:
        code = subprocess.run(command, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT).returncode
    seconds = time.perf_counter() - t0
    print(f"  {name:<28} {seconds:8.1f} s" + (f"   (exit {code}, {log})" if code else ""), flush=True)
    return seconds


def records(home: Path) -> list[dict]:
    """The run records (run.json) of a workspace."""
    found = []
    for path in (home / "runs").rglob("run.json"):
        try:
            found.append(json.loads(path.read_text()))
        except ValueError:
            continue
    return found


def _time(text: str | None) -> float | None:
    return datetime.fromisoformat(text).timestamp() if text else None


def breakdown(runs: list[dict], jobs: int) -> None:
    """Per target: runs, wall seconds (sum, largest), compile seconds; idle core-seconds of the run stage."""
    per = defaultdict(lambda: [0, 0.0, 0.0, 0.0, 0])
    for r in runs:
        row = per[r["target"]]
        wall = r.get("wall_time") or 0.0
        compile_time = (r.get("timing") or {}).get("compile", 0.0)
        row[0] += 1
        row[1] += wall
        row[2] = max(row[2], wall)
        row[3] += compile_time
        row[4] += compile_time > 5.0
    print(f"  {'target':<20} {'runs':>5} {'wall s':>8} {'longest':>8} {'compile s':>10} {'compiled':>9}")
    for target in sorted(per, key=lambda t: -per[t][1]):
        n, wall, longest, compile_time, compiled = per[target]
        print(f"  {target:<20} {n:>5} {wall:>8.1f} {longest:>8.1f} {compile_time:>10.1f} {compiled:>9}")
    total = [sum(v[i] for v in per.values()) for i in range(5)]
    print(f"  {'all':<20} {total[0]:>5} {total[1]:>8.1f} {'':>8} {total[3]:>10.1f} {total[4]:>9}   "
          f"(compiled: runs with more than 5 s of compile)")
    spans = [(_time(r.get("started")), _time(r.get("finished"))) for r in runs]
    spans = [(a, b) for a, b in spans if a is not None and b is not None]
    if spans:
        first, last = min(a for a, _ in spans), max(b for _, b in spans)
        busy = sum(b - a for a, b in spans)
        tail_start = last - 60.0
        tail_busy = sum(max(0.0, b - max(a, tail_start)) for a, b in spans)
        print(f"  run stage span {last - first:.1f} s on {jobs} slots: {jobs * (last - first) - busy:.1f} "
              f"core-seconds idle, {jobs * 60.0 - tail_busy:.1f} of them in the last minute")
    dem_walls = [r["wall_time"] for r in runs if r.get("adapter") == "dem" and r.get("wall_time")]
    if dem_walls:
        print(f"  dem runs: median wall {statistics.median(dem_walls):.2f} s, "
              f"median compile {statistics.median((r.get('timing') or {}).get('compile', 0.0) for r in runs if r.get('adapter') == 'dem'):.2f} s")


#: the Debian packages of scripts/setup.sh: the main job's, then the rest of everything
MAIN_PACKAGES = ["liggghts", "liggghts-doc", "lammps", "yade", "openmpi-bin"]
ALL_PACKAGES = MAIN_PACKAGES + ["lammps-examples", "chromium", "make", "gcc", "postgresql", "cmake", "g++", "ccache",
                                "libopenmpi-dev", "libvtk9-dev", "qtbase5-dev", "libqt5opengl5-dev", "linux-perf",
                                "python3-paraview-"]


def minimal_status(folder: Path) -> Path:
    """A dpkg status file of a minimal Debian: this machine's installed packages of priority required or
    important (or essential) and, recursively, what they depend on."""
    paragraphs = [p for p in Path("/var/lib/dpkg/status").read_text().split("\n\n") if p.strip()]
    installed, provided = {}, {}
    for paragraph in paragraphs:
        fields = dict(re.findall(r"^([A-Za-z-]+): (.*)$", paragraph, re.M))
        if "installed" in fields.get("Status", "") and "Package" in fields:
            installed[fields["Package"]] = (paragraph, fields)
            for name in fields.get("Provides", "").split(","):
                provided.setdefault(name.strip().split(" ")[0], fields["Package"])
    keep = {name for name, (_, f) in installed.items()
            if f.get("Priority") in ("required", "important") or f.get("Essential") == "yes"}
    todo = list(keep)
    while todo:
        fields = installed[todo.pop()][1]
        for dependency in (fields.get("Depends", "") + "," + fields.get("Pre-Depends", "")).split(","):
            for alternative in dependency.split("|"):
                name = alternative.strip().split(" ")[0].split(":")[0]
                name = name if name in installed else provided.get(name)
                if name:
                    if name not in keep:
                        keep.add(name)
                        todo.append(name)
                    break
    path = folder / "status"
    path.write_text("\n\n".join(installed[name][0] for name in sorted(keep)) + "\n\n")
    return path


def apt_estimate(status: Path, packages: list[str], recommends: bool) -> str:
    """Packages, download and installed size of installing packages on the system of the status file."""
    command = ["apt-get", "-s", "-o", f"Dir::State::status={status}", "install", *packages]
    if not recommends:
        command.append("--no-install-recommends")
    out = subprocess.run(command, capture_output=True, text=True).stdout
    names = [line.split()[1] for line in out.splitlines() if line.startswith("Inst ")]
    if not names:
        return "apt-get found nothing to install (no apt, or the simulation failed)"
    shown = subprocess.run(["apt-cache", "show", "--no-all-versions", *names], capture_output=True, text=True).stdout
    size = sum(int(v) for v in re.findall(r"^Size: (\d+)", shown, re.M))
    installed = sum(int(v) for v in re.findall(r"^Installed-Size: (\d+)", shown, re.M))
    return f"{len(names)} packages, {size / 1e6:.0f} MB to download, {installed / 1e3:.0f} MB installed"


def install_estimate(pip: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        status = minimal_status(Path(tmp))
        print("Debian packages on a minimal Debian (apt-get -s):")
        print(f"  setup.sh (everything, with recommends):   {apt_estimate(status, ALL_PACKAGES, True)}")
        print(f"  setup.sh main (main job, no recommends):  {apt_estimate(status, MAIN_PACKAGES, False)}")
        print(f"  the main job's packages with recommends:  {apt_estimate(status, MAIN_PACKAGES, True)}", flush=True)
        if pip:
            # a clone: an editable install writes its metadata into the source folder
            src, venv = Path(tmp) / "src", Path(tmp) / "venv"
            subprocess.run(["git", "clone", "-q", str(REPO), str(src)], check=True)
            subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
            for what in (".", ".[test]"):
                t0 = time.perf_counter()
                subprocess.run([str(venv / "bin" / "pip"), "install", "-q", "--no-cache-dir",
                                "--disable-pip-version-check", "-e", what], cwd=src, check=True)
                print(f"  pip install -e {what:<8} in a new venv: {time.perf_counter() - t0:.1f} s "
                      f"(load average {os.getloadavg()[0]:.1f})", flush=True)


def start_up(src: Path, cache: Path, work: Path) -> float:
    """Wall seconds of the fastest of three warm 1-particle engine runs (imports, cached kernels, 100 steps)."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from engine_coldstart import ONE_PARTICLE

    work.mkdir(parents=True, exist_ok=True)
    (work / "scene.json").write_text(json.dumps(ONE_PARTICLE))
    env = dict(os.environ, PYTHONPATH=str(src), DEM_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="1")
    times = []
    for _ in range(4):  # the first one compiles the 1-particle scene's kernel if the collection had none like it
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json"], cwd=work, env=env, capture_output=True)
        times.append(time.perf_counter() - t0)
    return min(times[1:])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rev", default="HEAD", help="revision of this repository (default HEAD)")
    parser.add_argument("-j", dest="jobs", type=int, default=2, help="harness run -j N (default 2)")
    parser.add_argument("--no-warm", action="store_true", help="skip the warm pass")
    parser.add_argument("--keep", type=Path, help="work in this (new) folder and keep it")
    parser.add_argument("--analyze", type=Path, metavar="HOME", help="only the breakdown of this workspace")
    parser.add_argument("--install", action="store_true", help="only the estimate of a fresh installation")
    parser.add_argument("--pip", action="store_true", help="with --install: time pip in a new virtual environment")
    parser.add_argument("--write-times", type=Path, metavar="HOME",
                        help="ship the wall times of this workspace's runs (harness/execution/expected_times.json)")
    args = parser.parse_args()
    if args.write_times:
        sys.path.insert(0, str(REPO))
        from harness.execution.expected import SHIPPED, write_shipped

        runs = records(args.write_times)
        commits = sorted({(r.get("build") or {}).get("commit", "")[:12] for r in runs if r.get("target") == "dem"})
        count = write_shipped(runs, f"benchmarks/main_job.py, dem at {', '.join(commits)}, "
                                    f"{datetime.now():%Y-%m-%d}, -j {args.jobs} on {os.cpu_count()} cores")
        print(f"{count} runs' wall times written to {SHIPPED}")
        return
    if args.install:
        install_estimate(args.pip)
        return
    if args.analyze:
        breakdown(records(args.analyze), args.jobs)
        return
    with tempfile.TemporaryDirectory() as tmp:
        root = args.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        src, home, cache = root / "src", root / "home", root / "cache"
        subprocess.run(["git", "clone", "-q", "--no-checkout", str(REPO), str(src)], check=True)
        commit = subprocess.run(["git", "rev-parse", args.rev], cwd=REPO, capture_output=True, text=True,
                                check=True).stdout.strip()
        subprocess.run(["git", "checkout", "-q", commit], cwd=src, check=True)
        (src / ".harness").mkdir()
        (src / ".harness" / ".installed").touch()
        env = dict(os.environ, PYTHONPATH=str(src), HARNESS_HOME=str(home), DEM_CACHE_DIR=str(cache))
        print(f"main job at {commit[:12]}, -j {args.jobs}, load average {os.getloadavg()[0]:.1f} "
              f"on {os.cpu_count()} cores (workspace {root})", flush=True)
        times = {}
        times["setup"] = stage("setup.sh (installed)", ["bash", "scripts/setup.sh"], src, env, root / "setup.log")
        times["build"] = stage("harness build", ["harness", "build"], src, env, root / "build.log")
        times["run"] = stage(f"harness run -j {args.jobs} (cold)", ["harness", "run", "-j", str(args.jobs)], src,
                             env, root / "run.log")
        times["check"] = stage("harness check --junit", ["harness", "check", "--junit", str(root / "junit.xml")],
                               src, env, root / "check.log")
        # the workspace is removed at the end: the verdict goes into this output (its summary, the failed rows
        # with their messages whole)
        verdict = (root / "check.log").read_text().splitlines()
        print("  check: " + (verdict[-1] if verdict else "no output"), flush=True)
        if verdict and " 0 failed" not in verdict[-1]:
            detail = subprocess.run(["harness", "check", "-v", "--wide"], cwd=src, env=env, capture_output=True,
                                    text=True).stdout.splitlines()
            for line in detail:
                if line.startswith("  ") and ": failed" in line:      # -v: a line per failed run, its message
                    print("    " + line.strip(), flush=True)
        total = sum(times.values())
        print(f"  {'main job':<28} {total:8.1f} s   (load average now {os.getloadavg()[0]:.1f})", flush=True)
        print("cold run stage:")
        breakdown(records(home), args.jobs)
        if not args.no_warm:
            warm = stage(f"harness run -j {args.jobs} --all (warm)",
                         ["harness", "run", "-j", str(args.jobs), "--all"], src, env, root / "warm.log")
            print("warm run stage:")
            breakdown(records(home), args.jobs)
            print(f"cold/warm run stage: {times['run']:.1f} / {warm:.1f} = {times['run'] / warm:.2f}")
        print(f"engine start-up (warm 1-particle run): {start_up(src, cache, root / 'one'):.2f} s")


if __name__ == "__main__":
    main()
