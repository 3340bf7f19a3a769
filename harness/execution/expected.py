"""How long a run is expected to take (wall seconds): what the order in which runs start (`scheduler.run_order`)
and the estimate of the time left (`scheduler.time_left`) go by.

A run's expected time is its last wall time on this machine (any build of its target), else the wall time
shipped with the repository in `expected_times.json` beside this module (the runs of the default collection,
the last wall time of each in one main job, i.e. its second pass, with the kernels cached: `python
benchmarks/main_job.py --write-times HOME`), else
unknown. So a fresh machine, whose workspace has no record yet, still starts its long runs first instead of
finding them out at the end with one slot busy and the others idle. Another machine is faster or slower, but the
order of the runs' lengths is what the scheduler uses, and that it keeps.
"""
from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

#: the shipped wall times: {"seconds": {target: {test case path: {run name: seconds}}}, "measured": what, where}
SHIPPED = Path(__file__).with_name("expected_times.json")


@lru_cache(maxsize=None)
def _read_shipped(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}  # no figures: every run unknown, as before the file existed
    seconds = data.get("seconds") if isinstance(data, dict) else None
    return seconds if isinstance(seconds, dict) else {}


def shipped_times(target: str, path: Path | None = None) -> dict:
    """(test case path, run name) -> wall seconds shipped for target's runs (empty if none); path: the shipped
    file (default SHIPPED)."""
    runs = _read_shipped(path or SHIPPED).get(target)
    if not isinstance(runs, dict):
        return {}
    return {(case, name): float(wall) for case, names in runs.items() if isinstance(names, dict)
            for name, wall in names.items() if isinstance(wall, (int, float)) and wall >= 0}


def expected_times(target: str, machine: str, path: Path | None = None) -> dict:
    """(test case path, run name) -> expected wall seconds of target's runs on machine: the last wall time of
    each in the store, else the shipped one (module docstring)."""
    from harness.store.models import Run  # the store's models load once Django is set up (harness.store)

    times = shipped_times(target, path)
    last: dict = {}
    for case, name, wall in (Run.objects.filter(machine__name=machine, target__name=target, wall_time__isnull=False)
                             .order_by("-finished").values_list("testcase__path", "name", "wall_time")):
        last.setdefault((case, name), wall)
    times.update(last)
    return times


def write_shipped(records: list[dict], measured: str, path: Path | None = None) -> int:
    """Write the wall times of run records (run.json contents of a workspace) as the shipped file; the latest
    record of each (target, test case, run) counts. Returns the number of runs written."""
    latest: dict = {}
    for r in sorted(records, key=lambda r: r.get("finished") or ""):
        if isinstance(r.get("wall_time"), (int, float)):
            latest[(r["target"], r["testcase"], r["run"])] = r["wall_time"]
    seconds: dict = {}
    for (target, case, name), wall in sorted(latest.items()):
        seconds.setdefault(target, {}).setdefault(case, {})[name] = round(wall, 1)
    (path or SHIPPED).write_text(json.dumps({"measured": measured, "seconds": seconds}, indent=1) + "\n")
    _read_shipped.cache_clear()
    return len(latest)
