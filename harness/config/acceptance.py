"""Acceptance checks a run configuration can declare beyond "ran and is consistent with the reference".

Two kinds, both evaluated after post-processing on the run's data (``thermo`` and every declared series or
textfile, each a pandas DataFrame):

``expectations``: a list of statements about one quantity::

    {"quantity": "restitution.e", "at": "end", "value": 0.9, "rel_tol": 0.01}
    {"quantity": "thermo.ke", "at": "max", "upper": 1e-3}

``quantity`` is ``SERIES.COLUMN`` (``thermo.ke``), or a sum of such terms (``thermo.ke + thermo.rke``).
``at`` reduces the column to one number: ``end`` (default), ``start``, ``min``, ``max``, ``mean``.
The bound is ``value`` with ``rel_tol`` (fraction of |value|) and/or ``abs_tol``, or ``lower``/``upper``.
``engines`` (a list of adapter names) restricts it to the runs of targets with those engine adapters.

``stability``: checks that hard cases stay numerically stable::

    {"finite": true,                                   # no NaN/inf in any series (default true)
     "particle_count": {"column": "thermo.atoms", "max_loss": 0},
     "energy_never_grows": {"quantity": "thermo.ke + thermo.rke + thermo.pe", "rel_tol": 0.01, "after": 0.0},
     "energy_drift": {"quantity": "thermo.etotal", "rel_tol": 0.01},
     "max_overlap": {"quantity": "thermo.max_overlap", "upper": 0.1}}

Every run gets the default checks ``DEFAULT_STABILITY`` - all values finite, no particle lost, no blow-up -
unless its run configuration says otherwise: ``"particle_count": {"max_loss": 25}`` declares a loss (an
outlet), ``"blowup": {"max_overlap": 0.8}`` declares a hard case, ``"particle_count": false``, ``"finite":
false`` or ``"blowup": false`` drops one default, ``"stability": false`` drops them all.

``blowup``: the largest overlap / radius may not exceed ``max_overlap`` (default 0.5, the bundled engine's own
limit, engine/blowup.py): from thermo's ``max_overlap`` column, else from what the engine adapter reports
(the bundled engine's per-run ``max overlap`` in its log); an engine that reports neither is not checked. The
bundled engine gets the declared limit too (``DEM_BLOWUP_MAX_OVERLAP``), so it does not stop the run first.
A run that stops with every particle gone is thus never recorded as a success by default.

``energy_never_grows`` is for closed dissipative systems: no value may exceed the running minimum of what came
before by more than ``rel_tol`` times the scale of the quantity (its largest absolute value) plus ``abs_tol``.
``after`` (same unit as the series' first column, e.g. step) skips the start-up, where insertion may add energy.
``energy_drift`` is for conservative systems (e = 1): every value stays within ``rel_tol`` of the first one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness.config.jsonfile import Problem

#: the largest overlap / radius a run may reach before it counts as blown up (engine/blowup.py's default, and
#: the reason for it there: contact laws of small overlaps; at half a radius the forces are time-step artefacts)
BLOWUP_MAX_OVERLAP = 0.5
#: checks every run gets unless its run configuration opts out (see the module docstring)
DEFAULT_STABILITY = {"finite": True, "particle_count": {"max_loss": 0}, "blowup": {"max_overlap": BLOWUP_MAX_OVERLAP}}


def blowup_limit(entry: dict) -> float | None:
    """The blow-up overlap limit a run configuration declares: a number, ``math.inf`` when it switches the
    check off (``"blowup": false`` or ``"stability": false``), None when it declares nothing (the default)."""
    declared = entry.get("stability", {}) if isinstance(entry, dict) else {}
    if declared is False:
        return math.inf
    if not isinstance(declared, dict) or "blowup" not in declared:
        return None
    spec = declared["blowup"]
    if spec is False:
        return math.inf
    if isinstance(spec, dict) and _is_number(spec.get("max_overlap")):
        return float(spec["max_overlap"])
    return None


def stability_of(entry: dict) -> dict:
    """The stability checks a run configuration entry asks for, the defaults included (``false``: none)."""
    declared = entry.get("stability", {})
    if declared is False:
        return {}
    merged = {**DEFAULT_STABILITY, **(declared if isinstance(declared, dict) else {})}
    return {key: spec for key, spec in merged.items() if spec is not False}


@dataclass
class Verdict:
    """Outcome of one acceptance check. ``reason`` is ``expectation`` or ``stability``."""

    ok: bool
    reason: str
    message: str


# ---------------------------------------------------------------------------------------------- validation

def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def problems(entry: dict, at: tuple = ()) -> list[Problem]:
    """What the schema (``harness.config.runconfig``) cannot say about an entry's ``expectations`` and
    ``stability``: which bounds go together. Fields of the wrong type are the schema's problems and skipped."""
    found = []
    expectations = entry.get("expectations")
    for i, spec in enumerate(expectations if isinstance(expectations, list) else []):
        if not isinstance(spec, dict):
            continue
        if "value" in spec and "rel_tol" not in spec and "abs_tol" not in spec:
            found.append(Problem((*at, "expectations", i), "'value' needs 'rel_tol' or 'abs_tol'"))
        if "value" not in spec and "lower" not in spec and "upper" not in spec:
            found.append(Problem((*at, "expectations", i), "needs 'value' with a tolerance, or 'lower'/'upper'"))
    stability = entry.get("stability")
    for key, spec in (stability.items() if isinstance(stability, dict) else ()):
        if not isinstance(spec, dict):
            continue
        if key == "max_overlap" and "upper" not in spec:
            found.append(Problem((*at, "stability", key), "needs 'upper' (largest overlap allowed, as a fraction "
                                                         "of the radius)"))
        if key in ("energy_never_grows", "energy_drift") and "rel_tol" not in spec and "abs_tol" not in spec:
            found.append(Problem((*at, "stability", key), "needs 'rel_tol' or 'abs_tol'"))
    return found


# ---------------------------------------------------------------------------------------------- evaluation

class _MissingData(Exception):
    pass


def _column(data: dict, quantity: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Values of ``SERIES.COLUMN`` (or a sum of terms) and the abscissa of the first term's series."""
    total = None
    abscissa = None
    for term in quantity.split("+"):
        series_name, _, column = term.strip().partition(".")
        frame = data.get(series_name)
        if frame is None:
            raise _MissingData(f"{quantity}: no series {series_name!r} (have: {', '.join(sorted(data)) or 'none'})")
        if column not in frame.columns:
            raise _MissingData(f"{quantity}: series {series_name!r} has no column {column!r} "
                               f"(columns: {', '.join(map(str, frame.columns))})")
        values = np.asarray(frame[column], dtype=float)
        if total is None:
            total = values.copy()
            abscissa = np.asarray(frame.iloc[:, 0], dtype=float) if len(frame.columns) else None
        elif len(values) != len(total):
            raise _MissingData(f"{quantity}: terms have different lengths ({len(total)} and {len(values)})")
        else:
            total += values
    if total is None or len(total) == 0:
        raise _MissingData(f"{quantity}: no values")
    return total, abscissa


def reduce_values(values: np.ndarray, at: str) -> float:
    """One number from a column: end, start, min, max or mean."""
    return float({"end": lambda v: v[-1], "start": lambda v: v[0], "min": np.min, "max": np.max,
                  "mean": np.mean}[at](values))


def _bounds(spec: dict) -> tuple[float, float, str]:
    """(lower, upper, text) for a spec with value+tolerances or explicit lower/upper."""
    if "value" in spec:
        value = float(spec["value"])
        half = max(float(spec.get("rel_tol", 0.0)) * abs(value), float(spec.get("abs_tol", 0.0)))
        if "rel_tol" in spec and spec.get("rel_tol", 0) * abs(value) >= spec.get("abs_tol", 0):
            text = f"{value:.6g} +/- {100 * spec['rel_tol']:.3g} %"
        else:
            text = f"{value:.6g} +/- {half:.3g}"
        return value - half, value + half, f"{text} [{value - half:.6g}, {value + half:.6g}]"
    lower = float(spec.get("lower", -math.inf))
    upper = float(spec.get("upper", math.inf))
    return lower, upper, f"[{lower:.6g}, {upper:.6g}]"


def _check_expectation(spec: dict, data: dict) -> Verdict:
    at = spec.get("at", "end")
    label = spec.get("name") or f"{spec['quantity']} ({at})"
    try:
        values, _ = _column(data, spec["quantity"])
    except _MissingData as exc:
        return Verdict(False, "expectation", f"expectation {label}: {exc}")
    measured = reduce_values(values, at)
    lower, upper, text = _bounds(spec)
    ok = math.isfinite(measured) and lower <= measured <= upper
    relation = "within" if ok else "outside"
    return Verdict(ok, "expectation", f"expectation {label} = {measured:.6g} {relation} {text}")


def _check_finite(data: dict) -> Verdict:
    for name, frame in data.items():
        numeric = frame.select_dtypes(include="number")
        bad = ~np.isfinite(numeric.to_numpy(dtype=float))
        if bad.any():
            row, col = np.argwhere(bad)[0]
            at = frame.iloc[row, 0]
            return Verdict(False, "stability", f"stability finite: {name}.{numeric.columns[col]} is "
                                               f"{numeric.iat[row, col]} at {frame.columns[0]} {at}")
    return Verdict(True, "stability", "stability finite: all values finite")


def _check_particle_count(spec: dict, data: dict) -> Verdict:
    column = spec.get("column", "thermo.atoms")
    values, abscissa = _column(data, column)
    loss = float(values[0] - values.min())
    allowed = float(spec.get("max_loss", 0))
    ok = loss <= allowed
    message = f"stability particle_count: {column} lost {loss:g} particles (allowed {allowed:g})"
    if not ok and abscissa is not None:
        first = int(np.argmax(values < values[0] - allowed))
        message += f", first below the bound at {abscissa[first]:g}"
    return Verdict(ok, "stability", message)


def _tolerance(spec: dict, scale: float) -> float:
    return float(spec.get("rel_tol", 0.0)) * scale + float(spec.get("abs_tol", 0.0))


def _check_never_grows(spec: dict, data: dict) -> Verdict:
    values, abscissa = _column(data, spec["quantity"])
    if abscissa is not None and "after" in spec:
        keep = abscissa >= float(spec["after"])
        values, abscissa = values[keep], abscissa[keep]
    if len(values) < 2:
        return Verdict(True, "stability", f"stability energy_never_grows: {spec['quantity']}: too few values")
    running_min = np.minimum.accumulate(values)
    growth = values[1:] - running_min[:-1]
    tolerance = _tolerance(spec, float(np.max(np.abs(values))))
    worst = int(np.argmax(growth))
    ok = growth[worst] <= tolerance
    where = f" at {abscissa[worst + 1]:g}" if abscissa is not None else ""
    return Verdict(ok, "stability", f"stability energy_never_grows: {spec['quantity']} rose by "
                                    f"{growth[worst]:.6g}{where} above its earlier minimum "
                                    f"(tolerance {tolerance:.3g})")


def _check_drift(spec: dict, data: dict) -> Verdict:
    values, abscissa = _column(data, spec["quantity"])
    deviation = np.abs(values - values[0])
    tolerance = _tolerance(spec, abs(float(values[0])))
    worst = int(np.argmax(deviation))
    ok = deviation[worst] <= tolerance
    where = f" at {abscissa[worst]:g}" if abscissa is not None else ""
    return Verdict(ok, "stability", f"stability energy_drift: {spec['quantity']} moved {deviation[worst]:.6g}"
                                    f"{where} from its initial {values[0]:.6g} (tolerance {tolerance:.3g})")


def _check_max_overlap(spec: dict, data: dict) -> Verdict:
    values, abscissa = _column(data, spec["quantity"])
    worst = int(np.nanargmax(values))
    ok = values[worst] <= float(spec["upper"])
    where = f" at {abscissa[worst]:g}" if abscissa is not None else ""
    return Verdict(ok, "stability", f"stability max_overlap: {spec['quantity']} reached {values[worst]:.4g}"
                                    f"{where} (bound {float(spec['upper']):.4g})")


def _check_blowup(spec: dict, data: dict) -> Verdict:
    """The largest overlap / radius the run reached, from thermo's max_overlap column or, without one, the
    engine's own report (``engine_log``: per run block, from the engine adapter's ``largest_overlaps``)."""
    thermo = data.get("thermo")
    quantity = "thermo.max_overlap" if thermo is not None and "max_overlap" in thermo.columns \
        else "engine_log.max_overlap"
    values, abscissa = _column(data, quantity)
    limit = float(spec["max_overlap"])
    worst = int(np.nanargmax(values)) if np.isfinite(values).any() else 0
    ok = bool(values[worst] <= limit)
    where = f" at {data[quantity.split('.')[0]].columns[0]} {abscissa[worst]:g}" if abscissa is not None else ""
    return Verdict(ok, "stability", f"stability blowup: largest overlap {values[worst]:.3g} of the radius "
                   f"({quantity}){where}" + (f", above the limit {limit:g}: the run blew up (a declared hard case "
                   "relaxes it with stability.blowup.max_overlap)" if not ok else f" (limit {limit:g})"))


_STABILITY = {
    "blowup": _check_blowup,
    "particle_count": _check_particle_count,
    "energy_never_grows": _check_never_grows,
    "energy_drift": _check_drift,
    "max_overlap": _check_max_overlap,
}


def applies(spec: dict, engine: str | None) -> bool:
    """Whether an expectation holds for a run of the engine adapter ``engine`` (its ``engines``, default all;
    None: the engine is not known, every expectation applies)."""
    engines = spec.get("engines")
    return engine is None or engines is None or engine in engines


def evaluate(entry: dict, data: dict, folder: Path | None = None, engine: str | None = None) -> list[Verdict]:
    """Evaluate every expectation and stability check of a run configuration entry.

    ``data`` maps series names (``thermo`` and the declared series/textfiles) to DataFrames whose first column
    is the abscissa. ``folder`` is the run folder (unused by the built-in checks, kept for checks that read
    artifacts). ``engine`` is the adapter name of the run's target: an expectation whose ``engines`` leave it
    out is not evaluated. Returns one Verdict per check; a run fails when any verdict is not ok.
    """
    verdicts = [_check_expectation(spec, data) for spec in entry.get("expectations", []) if applies(spec, engine)]
    stability = stability_of(entry)
    if stability.get("finite") and data:
        verdicts.append(_check_finite(data))
    declared = entry.get("stability") if isinstance(entry.get("stability"), dict) else {}
    for key, check in _STABILITY.items():
        if key in stability:
            try:
                verdicts.append(check(stability[key], data))
            except _MissingData as exc:
                if key in declared:  # a default check needs no data the run does not have
                    verdicts.append(Verdict(False, "stability", f"stability {key}: {exc}"))
    return verdicts
