"""Version consistency (thesis 4.4): a run's trajectories against the reference target's run.

For a reference trajectory x_ref,k and a run's x_k on the same abscissa (time step):

    eps     = 0.1 (max_k x_ref,k - min_k x_ref,k) / 2          (thesis eq. 4.2)
    Delta_k = 0.1 |x_k - x_ref,k| / eps                          (thesis eq. 4.3)
    C       = 1 - max_k Delta_k                                  (thesis eq. 4.4)

Levels: perfect when C >= 0.95 (every deviation below 5 %), good when C >= 0.9, else inconsistent.

Beyond the thesis:

* a floor for eps: a flat reference (a settled bed, a constant particle count) has max = min and would make
  every difference fatal; eps is at least ``floor`` (per quantity in run.config, default
  1e-6 max_k |x_ref,k|, i.e. round-off of the printed values);
* per-quantity overrides in run.config: ``"consistency": {"ke": {"epsilon": 1e-3, "floor": 1e-9}}``
  (``epsilon`` replaces eq. 4.2, same unit as the quantity), ``{"ignore": true}`` leaves a quantity out;
* the first abscissa value where |x_k - x_ref,k| > eps (the trajectory leaves its band);
* runs of different length (one stopped early) are scored on their common steps and reported as
  ``length_mismatch``, which counts as inconsistent;
* thermo columns the reference has and the run lacks are not compared, except the required atoms, ke and
  rke (thesis 4.4.1), which are reported ``missing`` (so another code with other thermo columns can be the
  reference);
* text files (thesis 4.4.3) are compared word by word; numbers within eps = max(rtol |ref|, atol)
  (rtol default 0.1, the same 10 % margin), scored with eq. 4.3.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from harness.execution.postprocess import is_number

PERFECT, GOOD, INCONSISTENT = "perfect", "good", "inconsistent"
LENGTH_MISMATCH, MISSING = "length_mismatch", "missing"
FAILING_LEVELS = (INCONSISTENT, LENGTH_MISMATCH, MISSING)
#: thermo columns that measure the computer, not the physics
NOT_PHYSICS = {"cpu", "cpuremain", "elapsed", "elaplong", "wall", "wall_time", "walltime"}
#: thermo columns that are an axis (the step, the simulated time = steps x dt): neither scored nor plotted as
#: quantities unless run.config's ``consistency`` names them (e.g. ``{"time": {}}`` when dt is under test)
AXIS_COLUMNS = {"step", "time"}
#: thermo quantities every run must have (thesis 4.4.1); other reference columns are compared when present
REQUIRED_THERMO = ("atoms", "ke", "rke")
RELATIVE_FLOOR = 1e-6
TINY = 1e-300


@dataclass
class Score:
    value: float            # C
    level: str
    epsilon: float
    first_bad: int | None   # index into the compared points, None if all inside the band
    points: int


def level_of(value: float) -> str:
    if value >= 0.95:
        return PERFECT
    if value >= 0.9:
        return GOOD
    return INCONSISTENT


def score(reference, values, epsilon: float | None = None, floor: float | None = None,
          band_reference=None) -> Score:
    """Score ``values`` against ``reference`` (same length) after eqs. 4.2-4.4, vectorised.

    ``band_reference`` (default ``reference``) is the trajectory eps is taken from (the whole reference when
    only a prefix is compared).
    """
    ref = np.asarray(reference, dtype=float)
    x = np.asarray(values, dtype=float)
    band = ref if band_reference is None else np.asarray(band_reference, dtype=float)
    if epsilon is None:
        finite = band[np.isfinite(band)]
        epsilon = 0.1 * (finite.max() - finite.min()) / 2.0 if finite.size else 0.0
        if floor is None:
            floor = RELATIVE_FLOOR * (np.abs(finite).max() if finite.size else 0.0)
        epsilon = max(epsilon, floor, TINY)
    if ref.size == 0:
        return Score(1.0, PERFECT, float(epsilon), None, 0)
    deviation = np.abs(x - ref)
    # NaN on either side is a deviation without bound; equal infinities are not
    deviation = np.where(np.isnan(deviation) & ~(ref == x), np.inf, np.nan_to_num(deviation, nan=0.0))
    delta_max = 0.1 * float(deviation.max()) / epsilon
    outside = np.flatnonzero(deviation > epsilon)
    value = 1.0 - delta_max
    value = max(value, -1e300)  # keep it a finite number for JSON and the store
    return Score(value, level_of(value), float(epsilon), int(outside[0]) if outside.size else None, ref.size)


@dataclass
class QuantityResult:
    series_kind: str
    series_name: str
    quantity: str
    value: float | None
    level: str
    epsilon: float | None = None
    first_bad_step: float | None = None
    message: str = ""

    @property
    def failing(self) -> bool:
        return self.level in FAILING_LEVELS


def compare_trajectory(kind: str, name: str, quantity: str, x_ref, y_ref, x, y,
                       settings: dict | None = None) -> QuantityResult:
    """One quantity of one series against the reference on the abscissa (step) axis."""
    settings = settings or {}
    x_ref, y_ref = np.asarray(x_ref, dtype=float), np.asarray(y_ref, dtype=float)
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    epsilon, floor = settings.get("epsilon"), settings.get("floor")
    if x.shape == x_ref.shape and np.array_equal(x, x_ref):
        s = score(y_ref, y, epsilon, floor)
        first = float(x_ref[s.first_bad]) if s.first_bad is not None else None
        msg = "" if s.first_bad is None else f"leaves its band (eps {s.epsilon:.4g}) at step {first:g}"
        return QuantityResult(kind, name, quantity, s.value, s.level, s.epsilon, first, msg)
    n = min(x.size, x_ref.size)
    if np.array_equal(x[:n], x_ref[:n]):
        # the usual case: one run stopped early (or went on); the common steps are a prefix
        common, i_ref, i_run = x_ref[:n], np.arange(n), np.arange(n)
    else:
        common, i_ref, i_run = np.intersect1d(x_ref, x, assume_unique=False, return_indices=True)
    if common.size == 0:
        return QuantityResult(kind, name, quantity, None, LENGTH_MISMATCH, None, None,
                              f"no common steps (run {x.size} points up to {x.max() if x.size else 0:g}, "
                              f"reference {x_ref.size} up to {x_ref.max() if x_ref.size else 0:g})")
    s = score(y_ref[i_ref], y[i_run], epsilon, floor, band_reference=y_ref)
    first = float(common[s.first_bad]) if s.first_bad is not None else None
    last_run = x.max() if x.size else 0
    last_ref = x_ref.max()
    how = (f"run stopped at step {last_run:g}, reference at {last_ref:g}" if last_run < last_ref
           else f"run went on to step {last_run:g}, reference stopped at {last_ref:g}" if last_run > last_ref
           else "steps differ")
    msg = (f"length mismatch: {x.size} points vs {x_ref.size} in the reference ({how}); "
           f"C = {s.value:.4g} on {common.size} common steps")
    if first is not None:
        msg += f"; leaves its band at step {first:g}"
    return QuantityResult(kind, name, quantity, s.value, LENGTH_MISMATCH, s.epsilon, first, msg)


def compare_words(name: str, ref_words: list[str], words: list[str], settings: dict | None = None) -> QuantityResult:
    """A text file word by word: words equal, numbers within eps = max(rtol |ref|, atol) (thesis 4.4.3)."""

    settings = settings or {}
    rtol, atol = float(settings.get("rtol", 0.1)), float(settings.get("atol", 1e-12))
    if len(ref_words) != len(words):
        return QuantityResult("textfile", name, "words", None, INCONSISTENT, None, None,
                              f"{len(words)} words, reference has {len(ref_words)}")
    numbers_ref, numbers = [], []
    for i, (a, b) in enumerate(zip(ref_words, words)):
        if is_number(a) and is_number(b):
            numbers_ref.append(float(a))
            numbers.append(float(b))
        elif a != b:
            return QuantityResult("textfile", name, "words", None, INCONSISTENT, None, None,
                                  f"word {i + 1} is {b!r}, reference {a!r}")
    if not numbers:
        return QuantityResult("textfile", name, "words", 1.0, PERFECT, None, None, "")
    ref = np.array(numbers_ref)
    x = np.array(numbers)
    eps = np.maximum(rtol * np.abs(ref), atol)
    delta = 0.1 * np.abs(x - ref) / eps
    delta = np.where(np.isnan(delta), np.inf, delta)
    worst = int(np.argmax(delta))
    value = max(1.0 - float(delta[worst]), -1e300)
    msg = "" if delta[worst] <= 0.1 else f"number {worst + 1}: {x[worst]:g}, reference {ref[worst]:g}"
    return QuantityResult("textfile", name, "words", value, level_of(value), float(eps[worst]), None, msg)


def axis_asked(overrides: dict | None, series_name: str, column: str) -> bool:
    """Whether run.config's ``consistency`` names an axis column (``time`` or ``thermo:time``) to be scored."""
    return bool(overrides) and (column in overrides or f"{series_name}:{column}" in overrides)


def _settings_for(overrides: dict, *names: str) -> dict:
    for name in names:
        if name in overrides:
            return overrides[name]
    return overrides.get("*", {})


def compare_runs(series: list[dict], reference: list[dict], overrides: dict | None = None) -> list[QuantityResult]:
    """All quantities of a run against its reference run.

    ``series`` / ``reference``: dicts with kind, name, x_column, columns (the store's Series). Thermo: every
    column but the step against the step; plots: every y column against the plot's x column; text files.
    """
    overrides = overrides or {}
    ours = {(s["kind"], s["name"]): s for s in series}
    results = []
    for ref in reference:
        kind, name = ref["kind"], ref["name"]
        if kind not in ("thermo", "plot", "textfile"):
            continue
        mine = ours.get((kind, name))
        if kind == "textfile":
            settings = _settings_for(overrides, name)
            if settings.get("ignore"):
                continue
            if mine is None:
                results.append(QuantityResult(kind, name, "words", None, MISSING, message="text file missing"))
            else:
                results.append(compare_words(name, ref["columns"].get("words", []),
                                             mine["columns"].get("words", []), settings))
            continue
        x_column = ref.get("x_column") or next(iter(ref["columns"]))
        for quantity, values in ref["columns"].items():
            if quantity == x_column or (kind == "thermo" and quantity.lower() in NOT_PHYSICS):
                continue
            if kind == "thermo" and quantity.lower() in AXIS_COLUMNS and not axis_asked(overrides, name, quantity):
                continue
            settings = _settings_for(overrides, quantity, f"{name}:{quantity}", name)
            if settings.get("ignore"):
                continue
            if (kind == "thermo" and mine is not None and quantity not in mine["columns"]
                    and quantity not in REQUIRED_THERMO):
                continue  # a column only the reference prints (another code, another thermo style)
            if mine is None or quantity not in mine["columns"] or x_column not in mine["columns"]:
                results.append(QuantityResult(kind, name, quantity, None, MISSING,
                                              message=f"{quantity} missing in the run's {kind} {name!r}"))
                continue
            # None (a non-finite value in the store's JSON) becomes NaN with dtype=float
            y_ref = np.array(values, dtype=float)
            y = np.array(mine["columns"][quantity], dtype=float)
            results.append(compare_trajectory(kind, name, quantity, ref["columns"][x_column], y_ref,
                                              mine["columns"][x_column], y, settings))
    return results


def run_level(results: list[QuantityResult]) -> tuple[str, float | None]:
    """The run's consistency level and lowest C."""
    values = [r.value for r in results if r.value is not None]
    lowest = min(values) if values else None
    if any(r.failing for r in results):
        return INCONSISTENT, lowest
    if any(r.level == GOOD for r in results):
        return GOOD, lowest
    return PERFECT, lowest
