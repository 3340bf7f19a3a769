"""Sampling profiles of runs as folded stacks, and what grew between two of them (thesis ch. 7.3-7.4).

A profiled run (``harness run --profile``, or ``"profile": true`` in its run.config entry) of a native code is
started under ``perf record -g`` (Linux perf: samples of the call stack, by default 249 per second, of the code
and every process it starts, so all MPI ranks under ``mpirun``; callers found by DWARF unwinding, see
``harness.config.runconfig.CALL_GRAPHS``); afterwards ``perf script`` prints the samples
and :func:`fold_perf_script` folds them into the *folded stacks* format of Brendan Gregg's flame graphs, one
line per distinct stack, root first, with its sample count::

    liggghts;main;LAMMPS_NS::Run::command;LAMMPS_NS::Verlet::run;LAMMPS_NS::PairGran::compute 412

For the bundled engine (a Python program whose native stacks show the interpreter, not the physics) the
profile is its own phase timers (``engine/runner.py``): ``run;pair``, ``run;neighbor``, ... weighted in
microseconds. Either way the run folder keeps ``profile.folded`` (``Run.profile``); the raw ``perf.data`` is
kept beside it for ``perf report`` until ``harness gc`` collects it (``harness.execution.gc.collect_profiles``).

Comparing two profiles (:func:`function_diff`) ranks functions by the growth of their *inclusive share*: the
fraction of samples whose stack contains the function. A function that got slower grows its own share and
its callers'; the deepest of them that grew most is where the time went.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from collections import Counter
from pathlib import Path

from harness.config.runconfig import PERF_FREQUENCY
from harness.analysis.breakdown import section_seconds

FOLDED_FILE = "profile.folded"
PERF_DATA = "perf.data"
DEFAULT_SETTINGS = {"call_graph": "dwarf", "frequency": PERF_FREQUENCY}


def settings(value) -> dict | None:
    """The perf settings of a run.config ``profile`` value (None: not profiled)."""
    if not value:
        return None
    return {**DEFAULT_SETTINGS, **(value if isinstance(value, dict) else {})}

_FRAME = re.compile(r"^\s*[0-9a-f]+\s+(.*?)\s+\((.*)\)\s*$")
_OFFSET = re.compile(r"\+0x[0-9a-f]+$")


def perf_available() -> str | None:
    """Why profiling with perf cannot work here (one line), or None when it can."""
    if shutil.which("perf") is None:
        return "perf is not installed (Debian: linux-perf)"
    try:
        paranoid = int(Path("/proc/sys/kernel/perf_event_paranoid").read_text())
    except (OSError, ValueError):
        return None
    if paranoid > 2 and os.geteuid() != 0:
        return f"kernel.perf_event_paranoid = {paranoid} forbids profiling (2 allows one's own processes)"
    return None


def perf_command(command: list[str], options: dict | None = None, output: str = PERF_DATA) -> list[str]:
    """``command`` under ``perf record -g`` writing ``output`` in the run folder; children are followed, so
    mpirun's ranks are sampled too. ``options``: ``call_graph`` and ``frequency`` (``settings``)."""
    options = {**DEFAULT_SETTINGS, **(options or {})}
    return (["perf", "record", "-g", "--call-graph", options["call_graph"], "-F", str(options["frequency"]), "-q",
             "-o", output, "--"] + list(command))


def enable(spec, adapter, value) -> None:
    """Make the run ``spec`` (``harness.execution.planning.make_spec``) a profiled run: its command under perf for a native
    code, its phase timers for the bundled engine (``EngineAdapter.profiler``)."""
    options = settings(value if value not in (None, False) else True)
    spec.profile = {"profiler": adapter.profiler, **options}
    if adapter.profiler == "perf":
        problem = perf_available()
        if problem:  # the run runs unprofiled and says why (finish), rather than failing to start
            spec.profile["problem"] = problem
        elif spec.command:
            spec.command = perf_command(spec.command, options)


def finish(spec, folder: Path, record) -> None:
    """After a profiled run (``spec``, a ``RunSpec``): its folded stacks in ``profile.folded`` and the
    ``RunRecord``'s ``profile`` naming them.
    A profile that cannot be made is a warning of the run, never its failure."""
    how = (spec.profile or {}).get("profiler")
    if not how:
        return
    if spec.profile.get("problem"):
        record.warnings.append(f"WARNING: no profile: {spec.profile['problem']}")
        return
    try:
        if how == "perf":
            if not (Path(folder) / PERF_DATA).is_file():
                raise RuntimeError("perf wrote no perf.data")
            stacks = fold_perf_data(Path(folder))
        else:
            stacks = phase_stacks(record.breakdown)
        if not stacks:
            raise RuntimeError("no samples")
        write_folded(Path(folder) / FOLDED_FILE, stacks)
        record.profile = FOLDED_FILE
    except (OSError, RuntimeError, subprocess.SubprocessError) as exc:
        record.warnings.append(f"WARNING: no profile: {exc}")


def _frame_name(symbol: str, dso: str) -> str:
    symbol = _OFFSET.sub("", symbol.strip())
    if not symbol or symbol == "[unknown]":
        return f"[{os.path.basename(dso.strip('[]')) or 'unknown'}]"
    return symbol.replace(";", ":")


def fold_perf_script(text: str) -> Counter:
    """Folded stacks (``"comm;outer;...;leaf"`` -> samples) of ``perf script`` output.

    ``perf script`` prints each sample as a header line (``comm pid time: period event:``) followed by its
    frames, leaf first, one per line (``address symbol+offset (library)``), and a blank line. The process name
    becomes the root frame; a frame without a symbol is named by its library (``[libc.so.6]``).
    """
    stacks: Counter = Counter()
    comm = None
    frames: list[str] = []

    def flush():
        if comm is not None:
            stacks[";".join([comm] + frames[::-1])] += 1

    for line in text.splitlines():
        if not line.strip():
            flush()
            comm, frames = None, []
            continue
        if not line[0].isspace():
            flush()
            comm, frames = line.split()[0].replace(";", ":"), []
            continue
        match = _FRAME.match(line)
        if match and comm is not None:
            frames.append(_frame_name(match.group(1), match.group(2)))
    flush()
    return stacks


def fold_perf_data(folder: Path, data: str = PERF_DATA, timeout: float = 600) -> Counter:
    """Fold the ``perf.data`` of a run folder (``perf script``, symbols resolved where the binaries are)."""
    result = subprocess.run(["perf", "script", "-i", data], cwd=folder, capture_output=True, text=True,
                            errors="replace", timeout=timeout)
    if result.returncode != 0:
        raise RuntimeError(f"perf script: {result.stderr.strip().splitlines()[-1:] or result.returncode}")
    return fold_perf_script(result.stdout)


def phase_stacks(breakdown: dict) -> Counter:
    """The bundled engine's profile: its phase timers as folded stacks, in microseconds (``run;pair`` ...)."""

    return Counter({f"run;{section}": int(round(seconds * 1e6))
                    for section, seconds in section_seconds(breakdown).items() if seconds > 0})


def write_folded(path: Path, stacks: Counter) -> None:
    lines = [f"{stack} {count}" for stack, count in sorted(stacks.items()) if count > 0]
    Path(path).write_text("\n".join(lines) + ("\n" if lines else ""))


def read_folded(path: Path) -> Counter:
    """Folded stacks of a file (``stack count`` lines; malformed lines are skipped)."""
    stacks: Counter = Counter()
    for line in Path(path).read_text(errors="replace").splitlines():
        stack, _, count = line.rpartition(" ")
        if stack and count.isdigit():
            stacks[stack] += int(count)
    return stacks


def run_profile(run) -> Counter | None:
    """The folded stacks of a stored run, or None when it was not profiled or its files were collected."""
    if not run.profile or not run.folder:
        return None
    path = Path(run.folder) / run.profile
    return read_folded(path) if path.is_file() else None


def function_shares(stacks: Counter) -> dict[str, tuple[float, float]]:
    """Per function: (inclusive share, self share) of all samples. A recursive function counts once per
    sample."""
    total = sum(stacks.values())
    inclusive: Counter = Counter()
    own: Counter = Counter()
    for stack, count in stacks.items():
        frames = stack.split(";")
        for name in set(frames):
            inclusive[name] += count
        own[frames[-1]] += count
    if not total:
        return {}
    return {name: (inclusive[name] / total, own[name] / total) for name in inclusive}


def function_diff(a: Counter, b: Counter) -> list[dict]:
    """Functions of two profiles, the one whose inclusive share grew most first; a tie (a function and the
    callers it passes its growth to) goes to the one with more own time growth, the deeper one."""
    sa, sb = function_shares(a), function_shares(b)
    rows = []
    for name in set(sa) | set(sb):
        ia, oa = sa.get(name, (0.0, 0.0))
        ib, ob = sb.get(name, (0.0, 0.0))
        rows.append({"function": name, "a": ia, "b": ib, "growth": ib - ia, "self_a": oa, "self_b": ob,
                     "self_growth": ob - oa})
    return sorted(rows, key=lambda r: (round(r["growth"], 6), r["self_growth"], r["function"]), reverse=True)


def format_function_diff(rows: list[dict], limit: int = 10) -> list[str]:
    lines = [f"  {'share A':>8}{'share B':>9}{'growth':>9}  {'self B':>7}  function"]
    for row in rows[:limit]:
        lines.append(f"  {row['a']:>8.1%}{row['b']:>9.1%}{row['growth']:>+9.1%}  {row['self_b']:>7.1%}  "
                     f"{row['function']}")
    return lines


def tree(stacks: Counter, root: str = "all") -> dict:
    """Folded stacks as the nested ``{"name", "value", "children"}`` tree a flame graph draws (``value``:
    inclusive samples)."""
    top = {"name": root, "value": 0, "children": {}}
    for stack, count in stacks.items():
        node = top
        node["value"] += count
        for frame in stack.split(";"):
            node = node["children"].setdefault(frame, {"name": frame, "value": 0, "children": {}})
            node["value"] += count
    return _listed(top)


def diff_tree(a: Counter, b: Counter, root: str = "all") -> dict:
    """B's tree, each node with ``delta``: its own (self) samples in B minus in A, A scaled to B's sample
    count; summed over a node's subtree that is the growth of the node's inclusive samples (a differential
    flame graph: B's shape, coloured by growth)."""
    total_a, total_b = sum(a.values()), sum(b.values())
    scale = total_b / total_a if total_a else 0.0
    scaled = Counter({stack: count * scale for stack, count in a.items()})
    index: dict[tuple, float] = {}
    for stack, count in scaled.items():
        path: tuple = ()
        index[path] = index.get(path, 0.0) + count
        for frame in stack.split(";"):
            path = path + (frame,)
            index[path] = index.get(path, 0.0) + count
    result = tree(b, root)

    def mark(node, path):
        inclusive = node["value"] - index.get(path, 0.0)
        below = sum(mark(child, path + (child["name"],)) for child in node.get("children", []))
        # d3-flame-graph's computeDelta sums a node's own delta and its children's: each node keeps its own
        node["delta"] = round(inclusive - below, 3)
        return inclusive

    mark(result, ())
    return result


def _listed(node: dict) -> dict:
    children = sorted(node["children"].values(), key=lambda c: c["name"])
    return {"name": node["name"], "value": node["value"], "children": [_listed(c) for c in children]}
