"""The rules the CLI and the dashboard share, each in one place so that they cannot disagree.

Pure predicates on a run's columns (nothing here reads the store, so every layer may import it):

- which run states count as a successful execution (thesis 4.3.4);
- which consistency levels pass (thesis 4.4.1);
- how a reviewer's override is honoured (whole run, or one quantity named ``q``, ``series:q`` or
  ``series.q``) and when a run counts as accepted (``is_accepted``; its SQL form is
  ``harness.store.queries.accepted_expression``, and tests/web/test_rules_agree.py checks that both agree);
- the gate: what ``harness check`` says of a covered run (``gate_status``);
- when a run is failing (``is_failing``; SQL form ``RunQuerySet.failing``): what ``harness list -q`` lists,
  what starts a "failing since" streak and what fails ``harness check`` besides the runs not executed;
- which state a run gets back when its build becomes current again;
- the measured noise of a run's stepping time (``relative_spread``) and when a stepping-time ratio is a speed
  change (``speed_kind``: beyond a threshold and beyond that noise), read by the history, the regressions, the
  overview, ``harness compare`` and ``bisect --slower``.

The store-side halves - the QuerySet methods ``current()``, ``failing()``, ``accepted()`` and the choice of a
reference run - are in ``harness.store.queries``.
"""
from __future__ import annotations

import statistics
from collections.abc import Iterable, Mapping

#: run states whose execution succeeded (thesis 4.3.4: executed, post-processed, checked)
SUCCESS_STATES = ("executed", "post_processed", "consistency_checked")
#: consistency levels that pass (thesis 4.4.1: perfect C >= 0.95, good C >= 0.9); every other level of a
#: quantity (inconsistent, length mismatch, missing) fails it
CONSISTENT_LEVELS = ("perfect", "good")
#: how an override may name a quantity of a series besides its bare name: ``series:q`` and ``series.q``
OVERRIDE_SEPARATORS = (":", ".")
#: the override quantity that accepts a whole run
WHOLE_RUN = ""


def override_keys(series_name: str, quantity: str) -> tuple[str, ...]:
    """The override quantities that accept ``quantity`` of ``series_name`` (besides a whole-run override)."""
    return (quantity, *(f"{series_name}{sep}{quantity}" for sep in OVERRIDE_SEPARATORS))


def quantity_fails(level: str) -> bool:
    """Whether a quantity's consistency level fails it (anything but perfect or good)."""
    return level not in CONSISTENT_LEVELS


def override_for(overrides: Mapping, series_name: str, quantity: str):
    """The value of the override in ``overrides`` (keyed by override quantity) that accepts ``quantity`` of
    ``series_name``: a whole-run override first, then one naming the quantity; None when none does."""
    if WHOLE_RUN in overrides:
        return overrides[WHOLE_RUN]
    return next((overrides[k] for k in override_keys(series_name, quantity) if k in overrides), None)


def is_accepted(state: str, consistency: str, overrides: Mapping, results: Iterable) -> bool:
    """Whether a reviewer overruled a run: a failed run by a whole-run override only; an inconsistent run by
    a whole-run override or by an override for each of its failing quantities. ``overrides`` is keyed by
    override quantity, ``results`` are (series name, quantity, level) of the run's ConsistencyResult rows.
    The SQL of the same rule is ``harness.store.queries.accepted_expression``."""
    if state == "failed":
        return WHOLE_RUN in overrides
    if consistency != "inconsistent":
        return False
    return all(override_for(overrides, series, quantity) is not None
               for series, quantity, level in results if quantity_fails(level))


def gate_status(state: str, failure_accepted: bool, open_inconsistency: bool, allow_missing: bool = False) -> str:
    """The gate's rule for one covered run: "passed", "failed" or "skipped" (shown as "not run").

    A failed run fails unless a reviewer accepted its failure (``failure_accepted``); a run of the covered
    build that was not executed fails unless ``allow_missing``, then it is skipped, as is an outdated run;
    every other run passes unless it has an inconsistency no reviewer accepted (``open_inconsistency``).
    ``harness.analysis.check.verdict_of`` (the CLI, ``harness ci``, both JUnit writers) and the dashboard's counts
    (``harness.store.queries.Tally``, from aggregated columns) call it."""
    if state == "failed":
        return "passed" if failure_accepted else "failed"
    if state == "not_executed":
        return "skipped" if allow_missing else "failed"
    if state == "outdated":
        return "skipped"
    return "failed" if open_inconsistency else "passed"


def restored_state(run) -> str:
    """The state of an outdated run whose build is current again: what its record says it ended as."""
    if run.failure_reason:
        return "failed"
    if run.finished is None:
        return "not_executed"
    return "consistency_checked" if run.consistency in (*CONSISTENT_LEVELS, "inconsistent") else "post_processed"


def effective_state(run) -> str:
    """The state a run has for its own build: an outdated run that no newer content replaced is outdated only
    because another build of its target is current, and is still what it ended as for its own build."""
    if run.state == "outdated" and not run.replaced:
        return restored_state(run)
    return run.state


def is_failing(run) -> bool:
    """Whether a run is failing: it failed (for its own build, ``effective_state``) or is inconsistent, and no
    reviewer accepted it (``run.accepted``, the annotation of ``RunQuerySet.with_accepted``). ``harness list
    -q``, the "failing since" streaks and ``harness check`` (whose other failures are runs not executed) share
    it; its SQL form is ``RunQuerySet.failing``."""
    if run.accepted:
        return False
    return effective_state(run) == "failed" or run.consistency == "inconsistent"


def relative_spread(timing) -> float:
    """The measured noise of a run's stepping time: (max - min) / median of its repeated stepping times
    (``timing["stepping_repeats"]``, ``harness run --repeat N``); 0 without repeats."""
    repeats = [t for t in ((timing or {}).get("stepping_repeats") or []) if isinstance(t, (int, float)) and t > 0]
    if len(repeats) < 2:
        return 0.0
    return (max(repeats) - min(repeats)) / statistics.median(repeats)


#: a stepping-time change smaller than this share is no speed change (regressions, the overview, compare)
SPEED_MARK = 0.1


def speed_kind(ratio: float | None, noise: float = 0.0, threshold: float = SPEED_MARK) -> str:
    """"slower", "faster" or "same" for a stepping-time ratio now / before (dimensionless): a change counts only
    when it reaches ``threshold`` (relative, e.g. 0.1 = 10 %; ``bisect --slower 1.2`` asks 0.2) *and*
    exceeds ``noise``, the measured spread of repeated stepping times (``relative_spread``, the larger of the
    two sides). "same" without a ratio."""
    if not ratio:
        return "same"
    change = abs(ratio - 1.0)
    if change < threshold or change <= noise:
        return "same"
    return "slower" if ratio > 1.0 else "faster"
