"""How a code scales with cores: strong and weak scaling studies of one run configuration (thesis ch. 7.2).

A run configuration declares a scaling block::

    "scaling": {"cores": [1, 2, 4]}                                        # strong: the same scene on more cores
    "scaling": {"cores": [1, 2, 4], "kind": "weak", "with": {"N": [4000, 8000, 16000]}}  # size grows with them

Discovery expands it into one ordinary run per core count, named ``NAME@cores=P``: for a code that
parallelises with MPI (LIGGGHTS, LAMMPS, a generic code) an ``mpi`` run on P ranks; for one that uses threads
(the bundled engine's Numba threads, YADE's OpenMP) a run whose NUMBA_NUM_THREADS and OMP_NUM_THREADS are P
(``EngineAdapter.parallelism``). ``with`` passes further variables, one value per core count (``-var N 8000``):
the size of a weak scaling study.

From the stepping times T(P) of the points (the code's own loop time: ``Run.stepping_time``), per point:

- speedup ``S(P) = T(1) / T(P)`` (strong), and for weak scaling the scaled speedup ``S(P) = P T(1) / T(P)``
  (P times the work in T(P));
- parallel efficiency ``E(P) = S(P) / P`` (1 is perfect);
- the Karp-Flatt experimentally determined serial fraction ``e(P) = (1/S - 1/P) / (1 - 1/P)`` (A. H. Karp and
  H. P. Flatt, Commun. ACM 33(5), 1990): roughly constant when the serial part limits scaling, growing with P
  when parallel overhead (communication, imbalance, thread wake-ups) does. Undefined at P = 1.

The baseline T(1) is the point with the fewest cores; when that is not 1 the figures are relative to it
(``S = T(P0) P0 / T(P)`` is not assumed). Scaling points are timed best alone: ``harness scaling`` runs them one
at a time (``-j 1``), and a study whose largest point uses more cores than the machine has says so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from harness.config.jsonfile import Problem
from harness.config.record import STATE_LABELS
from harness.config.sweep import point_entry

SEPARATOR = "@"


def point_name(name: str, cores: int) -> str:
    return f"{name}{SEPARATOR}cores={cores}"


def problems(entry: dict, at: tuple = ()) -> list[Problem]:
    """What the schema (``harness.config.runconfig.Scaling``) cannot say about a ``scaling`` block: distinct
    core counts, one value of each ``with`` variable per core count, a weak study's size, and what it cannot
    go with."""
    block = entry.get("scaling")
    if not isinstance(block, dict):
        return []
    found = []
    cores = block.get("cores")
    if isinstance(cores, list) and len(set(map(repr, cores))) != len(cores):
        found.append(Problem((*at, "scaling", "cores"), "core counts must be distinct"))
    companions = block.get("with", {})
    for name, column in (companions.items() if isinstance(companions, dict) else ()):
        if isinstance(column, list) and isinstance(cores, list) and len(column) != len(cores):
            found.append(Problem((*at, "scaling", "with", name), "must be a list with one value per core count"))
    if block.get("kind") == "weak" and not companions:
        found.append(Problem((*at, "scaling", "with"), "a weak scaling study grows the size with the cores: name "
                             "the variable and its values, e.g. {\"N\": [4000, 8000]}"))
    if "sweep" in entry:
        found.append(Problem((*at, "scaling"), "a run configuration has either a sweep or a scaling block, not "
                             "both"))
    if entry.get("type") == "mpi/custom":
        found.append(Problem((*at, "scaling"), "not with type mpi/custom (the study sets the ranks itself)"))
    return found


def expand(entry: dict, parallelism: str = "mpi") -> list[dict]:
    """The run configuration entries of a scaling study, one per core count; ``[entry]`` without one.

    ``parallelism`` is the code's (``EngineAdapter.parallelism``): ``mpi`` makes each point an mpi run on P
    ranks, ``threads`` a run on P threads (``scaling_point.threads``, read by ``harness.execution.scheduler.make_spec``).
    """
    block = entry.get("scaling")
    if not block:
        return [entry]
    points = []
    for i, cores in enumerate(block["cores"]):
        point = point_entry(entry, "scaling", i, point_name(entry["name"], cores), {})
        if parallelism == "mpi":
            point["type"], point["nprocs"] = "mpi", cores
        point["scaling_point"] = {"study": entry["name"], "cores": cores, "parallelism": parallelism,
                                  "kind": block.get("kind", "strong"), "spec": block}
        points.append(point)
    return points


def point_of(config: dict) -> dict | None:
    """The ``scaling_point`` a run configuration carries when ``expand`` made it (study name, cores >= 1); None
    for other runs, and for a run.config that writes a malformed one by hand."""
    point = config.get("scaling_point") if isinstance(config, dict) else None
    if not isinstance(point, dict) or not isinstance(point.get("study"), str):
        return None
    cores = point.get("cores")
    if isinstance(cores, bool) or not isinstance(cores, int) or cores < 1:
        return None
    return point


def thread_environment(config: dict) -> dict[str, str]:
    """Thread-count variables of a threaded scaling point (empty for other runs)."""
    point = point_of(config)
    if point is None or point.get("parallelism") != "threads":
        return {}
    return {"NUMBA_NUM_THREADS": str(point["cores"]), "OMP_NUM_THREADS": str(point["cores"])}


@dataclass
class ScalingPoint:
    """One point: core count, stepping time (s) and the figures derived from the study's baseline."""

    cores: int
    time: float | None
    state: str = ""
    run_id: int | None = None
    speedup: float | None = None
    efficiency: float | None = None
    serial_fraction: float | None = None
    imbalance: float | None = None


def figures(points: list[ScalingPoint], kind: str = "strong") -> list[ScalingPoint]:
    """``points`` sorted by cores, with speedup, parallel efficiency and Karp-Flatt serial fraction filled in
    relative to the point with the fewest cores (see the module docstring for the formulas)."""
    points = sorted(points, key=lambda p: p.cores)
    base = next((p for p in points if p.time), None)
    for point in points:
        if base is None or not point.time or base.time is None:
            continue
        relative = point.cores / base.cores  # the core ratio to the baseline (P when the baseline is 1 core)
        ratio = base.time / point.time
        point.speedup = ratio * relative if kind == "weak" else ratio
        point.efficiency = point.speedup / relative
        if relative > 1 and point.speedup > 0:
            point.serial_fraction = (1 / point.speedup - 1 / relative) / (1 - 1 / relative)
    return points


@dataclass
class Study:
    """A scaling study of one run configuration of one test case in one build, as found in the store."""

    testcase: str
    name: str
    kind: str
    parallelism: str
    points: list[ScalingPoint] = field(default_factory=list)

    @property
    def key(self) -> str:
        return f"{self.testcase}/{self.name}"

    def at_most_cores(self) -> ScalingPoint | None:
        """The point with the most cores that has figures (what the efficiency history follows)."""
        usable = [p for p in self.points if p.efficiency is not None]
        return usable[-1] if usable else None

    def as_dict(self) -> dict:
        return {"testcase": self.testcase, "name": self.name, "kind": self.kind, "parallelism": self.parallelism,
                "points": [p.__dict__ for p in self.points]}


def studies_in_store(runs) -> list[Study]:
    """Group stored runs that are scaling points (``config.scaling_point``) into studies, with figures.

    ``runs`` is a Run queryset, typically one build's runs on one machine, without replaced runs. A failed
    point has no time and no figures.
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.rules import SUCCESS_STATES

    groups: dict[tuple[str, str], list] = {}
    rows = (runs.filter(config__has_key="scaling_point").select_related("testcase")
            .only("id", "state", "config", "stepping_time", "breakdown", "testcase__path"))
    for run in rows:
        point = point_of(run.config)
        if point is not None:
            groups.setdefault((run.testcase.path, point["study"]), []).append(run)
    studies = []
    for (testcase, name), members in sorted(groups.items()):
        first = members[0].config["scaling_point"]
        points = []
        for run in members:
            ok = run.state in SUCCESS_STATES and run.stepping_time and math.isfinite(run.stepping_time)
            points.append(ScalingPoint(int(run.config["scaling_point"]["cores"]), run.stepping_time if ok else None,
                                       run.state, run.pk, imbalance=(run.breakdown or {}).get("imbalance")))
        studies.append(Study(testcase, name, first.get("kind", "strong"), first.get("parallelism", "mpi"),
                             figures(points, first.get("kind", "strong"))))
    return studies


def format_study(study: Study) -> list[tuple]:
    """Table rows of a study (header first), for the CLI."""
    rows = [("cores", "stepping s", "speedup", "efficiency", "serial fraction", "imbalance", "state")]
    for p in study.points:
        rows.append((str(p.cores), _cell(p.time, ".4g"), _cell(p.speedup, ".3f"), _cell(p.efficiency, ".0%"),
                     _cell(p.serial_fraction, ".3f"), _cell(p.imbalance, ".2f"), STATE_LABELS.get(p.state, p.state)))
    return rows


def _cell(value, spec: str) -> str:
    return "-" if value is None or value != value else format(value, spec)


def history(target_id: int, machine_id: int) -> dict[str, list[dict]]:
    """Per study (``testcase/name``) the figures at the most cores over the target's builds by commit date:
    ``[{"build", "commit", "committed_at", "cores", "speedup", "efficiency", "serial_fraction", "worse"}]``
    (``worse``: ``mark_worse``).

    A revision that scales worse shows as a drop of efficiency even when its one-core time holds.
    Three queries whatever the number of builds: the builds, their scaling runs, nothing per build.
    """
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build, Run
    from harness.store.rules import SUCCESS_STATES

    builds = {b.pk: b for b in Build.objects.filter(target_id=target_id, machine_id=machine_id)}
    runs = (Run.objects.filter(build_id__in=list(builds), config__has_key="scaling_point", replaced=False)
            .select_related("testcase").only("id", "build_id", "state", "config", "stepping_time", "testcase__path"))
    grouped: dict[tuple, list] = {}
    for run in runs:
        point = point_of(run.config)
        if point is not None:
            grouped.setdefault((run.testcase.path, point["study"], run.build_id), []).append(run)
    out: dict[str, list[dict]] = {}
    for (testcase, name, build_id), members in grouped.items():
        kind = members[0].config["scaling_point"].get("kind", "strong")
        points = figures([ScalingPoint(int(r.config["scaling_point"]["cores"]),
                                       r.stepping_time if r.state in SUCCESS_STATES else None, r.state, r.pk)
                          for r in members], kind)
        usable = [p for p in points if p.efficiency is not None and p.cores > points[0].cores]
        if not usable:
            continue
        build = builds[build_id]
        top = usable[-1]
        out.setdefault(f"{testcase}/{name}", []).append({
            "build": build_id, "commit": build.commit, "committed_at": build.committed_at or build.finished,
            "cores": top.cores, "speedup": top.speedup, "efficiency": top.efficiency,
            "serial_fraction": top.serial_fraction, "time_1": points[0].time})
    for rows in out.values():
        rows.sort(key=lambda r: (r["committed_at"] is None, r["committed_at"] or 0, r["build"]))
        mark_worse(rows)
    return dict(sorted(out.items()))


#: a build whose efficiency at the most cores is this fraction below the previous build's scales worse
WORSE_BY = 0.10


def mark_worse(rows: list[dict], worse_by: float = WORSE_BY) -> list[dict]:
    """``history`` rows with ``worse`` set where the efficiency fell by more than ``worse_by`` (relative) against
    the previous build at the same core count: a scaling regression, whatever the one-core time did."""
    previous = None
    for row in rows:
        row["worse"] = bool(previous and previous["cores"] == row["cores"] and previous["efficiency"]
                            and row["efficiency"] is not None
                            and row["efficiency"] < (1 - worse_by) * previous["efficiency"])
        previous = row
    return rows
