"""What accuracy costs in time: one run configuration over a grid of a variable.

A run configuration declares a sweep block::

    "sweep": {"variable": "DT_FRACTION", "values": [0.4, 0.2, 0.1, 0.05],
              "with": {"STEPS": [250, 500, 1000, 2000]},
              "error": {"quantity": "bounce.e", "at": "end", "exact": 0.9}}

``with`` sets further variables that change together with the swept one (here: the same simulated time).

Discovery expands it into one ordinary run per value, named ``NAME@VARIABLE=VALUE``, with the value passed as
``-var VARIABLE VALUE``, so the runs are executed, stored, post-processed and checked like any other. After they
ran, :func:`sweep_table` turns them into a table of (value, run time, quantity, error) and
:func:`observed_order` fits the convergence order: the slope of log(error) against log(value). Velocity-Verlet
should show about 2 when the swept variable is the time step.

The error is ``|q - exact|`` when ``error.exact`` is given, otherwise ``|q - q_finest|`` where the finest run
is the one with the smallest value (``"finest": "max"`` when larger means finer, e.g. a particle count).
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from harness.config.acceptance import reduce_values
from harness.config.jsonfile import Problem
from harness.execution.postprocess import is_number
from harness.store.rules import SUCCESS_STATES

SEPARATOR = "@"


def point_name(name: str, variable: str, value) -> str:
    return f"{name}{SEPARATOR}{variable}={value:g}" if isinstance(value, float) else f"{name}{SEPARATOR}{variable}={value}"


def problems(entry: dict, at: tuple = ()) -> list[Problem]:
    """What the schema (``harness.config.runconfig.Sweep``) cannot say about a ``sweep`` block: distinct
    values, one value of each ``with`` variable per sweep value."""
    sweep = entry.get("sweep")
    if not isinstance(sweep, dict) or not isinstance(sweep.get("values"), list):
        return []
    found = []
    values = sweep["values"]
    if len(set(map(repr, values))) != len(values):
        found.append(Problem((*at, "sweep", "values"), "values must be distinct"))
    companions = sweep.get("with", {})
    for name, column in (companions.items() if isinstance(companions, dict) else ()):
        if isinstance(column, list) and len(column) != len(values):
            found.append(Problem((*at, "sweep", "with", name), "must be a list with one value per sweep value"))
    return found


def point_entry(entry: dict, block: str, index: int, name: str, variables: dict) -> dict:
    """Point ``index`` of the sweep or scaling study (``block``: "sweep" or "scaling") of a run configuration
    entry: a copy of the entry without the block, named ``name``, with ``variables`` set and each of the block's
    ``with`` variables at its ``index``-th value (the scaling study's points are made here too,
    harness.analysis.scaling.expand)."""
    point = copy.deepcopy(entry)
    spec = point.pop(block)
    point["name"] = name
    values = point.setdefault("variables", {})
    values.update(variables)
    for variable, column in spec.get("with", {}).items():
        values[variable] = column[index]
    return point


def expand(entry: dict) -> list[dict]:
    """The run configuration entries of a sweep: one per value, or ``[entry]`` when there is no sweep."""
    sweep = entry.get("sweep")
    if not sweep:
        return [entry]
    points = []
    for i, value in enumerate(sweep["values"]):
        point = point_entry(entry, "sweep", i, point_name(entry["name"], sweep["variable"], value),
                            {sweep["variable"]: value})
        point["sweep_point"] = {"sweep": entry["name"], "variable": sweep["variable"], "value": value,
                                "spec": sweep}
        points.append(point)
    return points


@dataclass
class SweepPoint:
    """One executed point: the swept value, the run time (s; the engine's loop CPU or wall time where it reports
    one, else the process wall time) and the measured quantity."""

    value: float
    run_time: float | None
    quantity: float | None
    state: str = ""


def measure(error_spec: dict, data: dict) -> float | None:
    """The swept quantity of one run from its post-processed data (None when missing)."""
    series, _, column = error_spec["quantity"].partition(".")
    frame = data.get(series)
    if frame is None or column not in frame.columns or len(frame) == 0:
        return None
    return reduce_values(np.asarray(frame[column], dtype=float), error_spec.get("at", "end"))


def sweep_table(sweep: dict, points: list[SweepPoint]) -> pd.DataFrame:
    """Table of value, run_time, quantity and error, sorted from coarse to fine."""
    finest_is_max = sweep.get("finest", "min") == "max"
    table = pd.DataFrame([p.__dict__ for p in points]).sort_values("value", ascending=finest_is_max)
    table = table.reset_index(drop=True)
    error = sweep["error"]
    if "exact" in error:
        reference = float(error["exact"])
    else:
        finest = table.dropna(subset=["quantity"])
        reference = float(finest["quantity"].iloc[-1]) if len(finest) else math.nan
    table["error"] = (table["quantity"] - reference).abs()
    if "exact" not in error and len(table):
        # the finest run is the reference itself: its error is not a measurement
        table.loc[table.index[-1], "error"] = math.nan
    return table


def observed_order(x, error) -> float | None:
    """Least-squares slope of log(error) against log(x), over points with positive finite error."""
    x = np.asarray(x, dtype=float)
    error = np.asarray(error, dtype=float)
    keep = np.isfinite(x) & np.isfinite(error) & (error > 0) & (x > 0)
    if keep.sum() < 2:
        return None
    slope, _ = np.polyfit(np.log(x[keep]), np.log(error[keep]), 1)
    return float(slope)


def plot(table: pd.DataFrame, sweep: dict, title: str, path) -> None:
    """Log-log plots side by side: error against run time (the cost of accuracy) and error against the value."""
    # a heavy library, loaded when this runs, not at every `harness` start
    import matplotlib

    matplotlib.use("Agg")
    # a heavy library, loaded when this runs, not at every `harness` start
    import matplotlib.pyplot as plt

    variable = sweep["variable"]
    quantity = sweep["error"]["quantity"]
    valid = table.dropna(subset=["error", "run_time"])
    valid = valid[valid["error"] > 0]
    fig, (cost, conv) = plt.subplots(1, 2, figsize=(11, 4.2))
    cost.loglog(valid["run_time"], valid["error"], "o-", color="tab:blue")
    for _, row in valid.iterrows():
        cost.annotate(f"{variable}={row['value']:g}", (row["run_time"], row["error"]), fontsize=8,
                      textcoords="offset points", xytext=(4, 4))
    cost.set_xlabel("run time [s] (engine time stepping)")
    cost.set_ylabel(f"error of {quantity}")
    cost.set_title("What accuracy costs in time")
    cost.grid(True, which="both", alpha=0.3)

    order = observed_order(valid["value"], valid["error"])
    conv.loglog(valid["value"], valid["error"], "o-", color="tab:red",
                label=f"observed order {order:.2f}" if order is not None else "measured")
    if order is not None and len(valid):
        x0, e0 = valid["value"].iloc[0], valid["error"].iloc[0]
        xs = np.array([valid["value"].min(), valid["value"].max()])
        conv.loglog(xs, e0 * (xs / x0) ** 2, "--", color="gray", label="order 2 (reference slope)")
    conv.set_xlabel(variable)
    conv.set_ylabel(f"error of {quantity}")
    conv.set_title("Convergence")
    conv.grid(True, which="both", alpha=0.3)
    conv.legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------------------ from the store

def _textfile_table(words: list[str]) -> pd.DataFrame | None:
    """A text file stored as words read back as a table: header words, then rows of numbers (else None)."""

    width = next((i for i, word in enumerate(words) if is_number(word)), len(words))
    values = words[width:]
    if width == 0 or not values or len(values) % width or not all(is_number(v) for v in values):
        return None
    return pd.DataFrame(np.array(values, dtype=float).reshape(-1, width), columns=words[:width])


def series_frames(run) -> dict[str, pd.DataFrame]:
    """A stored run's post-processed series as DataFrames keyed by name, abscissa column first.

    A text file with a numeric table (``restitution.txt``: ``e`` then ``0.9``) is also keyed by its stem.
    """
    frames = {}
    for series in run.series.all():
        if series.kind == "textfile":
            table = _textfile_table(series.columns.get("words", []))
            if table is not None:
                frames[series.name.rsplit(".", 1)[0]] = table
            continue
        frame = pd.DataFrame(series.columns)
        if series.x_column in frame.columns:
            frame = frame[[series.x_column] + [c for c in frame.columns if c != series.x_column]]
        frames[series.name] = frame
    return frames


@dataclass
class SweepResult:
    """A sweep of one run configuration of one test case, as found in the store."""

    testcase: str
    name: str
    spec: dict
    table: pd.DataFrame

    @property
    def order(self) -> float | None:
        return observed_order(self.table["value"], self.table["error"])


def sweeps_in_store(runs) -> list[SweepResult]:
    """Group stored runs that are sweep points (``config.sweep_point``) into sweeps and tabulate them.

    ``runs`` is a Run queryset, typically one build's runs on one machine; the sweep block is taken from
    the points' run configuration (``config.sweep_point.spec``).
    """
    groups: dict[tuple[str, str], list] = {}
    for run in runs.filter(config__has_key="sweep_point").select_related("testcase").prefetch_related("series"):
        point = run.config["sweep_point"]
        groups.setdefault((run.testcase.path, point["sweep"]), []).append(run)
    results = []
    for (testcase, name), members in sorted(groups.items()):
        spec = members[0].config["sweep_point"]["spec"]
        points = []
        for run in members:
            ok = run.state in SUCCESS_STATES
            quantity = measure(spec["error"], series_frames(run)) if ok else None
            # the engine's own loop time, in CPU seconds where it reports them (runs share the cores): process
            # start-up and kernel compilation are no cost of accuracy
            timing = run.timing or {}
            run_time = timing.get("cpu") or timing.get("total") or run.wall_time
            points.append(SweepPoint(float(run.config["sweep_point"]["value"]), run_time, quantity, run.state))
        results.append(SweepResult(testcase, name, spec, sweep_table(spec, points)))
    return results


def current_sweeps() -> list[tuple[object, SweepResult]]:
    """The sweeps of the newest complete build of every target on every machine, as (build, sweep) pairs."""
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Build, Run

    latest = {}
    for build in (Build.objects.filter(status=Build.Status.COMPLETE, runs__config__has_key="sweep_point")
                  .select_related("target", "machine").order_by("finished", "id").distinct()):
        latest[(build.machine_id, build.target_id)] = build
    found = []
    for build in sorted(latest.values(), key=lambda b: (b.machine.name, b.target.name)):
        found += [(build, result) for result in sweeps_in_store(Run.objects.filter(build=build))]
    return found


def find_sweep(build, testcase: str, name: str) -> SweepResult | None:
    # the store's models (Django) load once Django is set up (harness.store)
    from harness.store.models import Run

    runs = Run.objects.filter(build=build, testcase__path=testcase)
    return next((r for r in sweeps_in_store(runs) if r.name == name), None)
