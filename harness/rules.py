"""The rules the CLI and the dashboard share, each in one place so that they cannot disagree.

- which run states count as a successful execution (thesis 4.3.4);
- which consistency levels pass (thesis 4.4.1);
- which run is the reference run of a run (thesis 4.4: same test case, same run name, same test case
  content, by the reference target - its current build first);
- how a reviewer's override is honoured (whole run, or one quantity named ``q``, ``series:q`` or
  ``series.q``);
- which state a run gets back when its build becomes current again.
"""
from __future__ import annotations

#: run states whose execution succeeded (thesis 4.3.4: executed, post-processed, checked)
SUCCESS_STATES = ("executed", "post_processed", "consistency_checked")
#: consistency levels that pass (thesis 4.4.1: perfect C >= 0.95, good C >= 0.9)
CONSISTENT_LEVELS = ("perfect", "good")
#: how an override may name a quantity of a series besides its bare name: ``series:q`` and ``series.q``
OVERRIDE_SEPARATORS = (":", ".")


def override_keys(series_name: str, quantity: str) -> tuple[str, ...]:
    """The override quantities that accept ``quantity`` of ``series_name`` (besides a whole-run override)."""
    return (quantity, *(f"{series_name}{sep}{quantity}" for sep in OVERRIDE_SEPARATORS))


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


def reference_candidates(run, reference_target: str):
    """Successful runs of ``reference_target`` that may serve as ``run``'s reference, best first.

    Same test case, run name and test case content; the reference target's current build on this machine
    first, then its newest runs on this machine, then on any machine (imported results).
    """
    from django.db.models import Case, IntegerField, Value, When

    from harness.models import Run

    return (Run.objects.filter(target__name=reference_target, testcase_id=run.testcase_id, name=run.name,
                               testcase_hash=run.testcase_hash, state__in=SUCCESS_STATES)
            .annotate(preference=Case(
                When(machine_id=run.machine_id, build__current=True, then=Value(0)),
                When(machine_id=run.machine_id, then=Value(1)), default=Value(2),
                output_field=IntegerField()))
            .order_by("preference", "-finished", "-id"))


def find_reference_run(run, reference_target: str | None):
    """The reference run of ``run`` by ``reference_target`` (None: no target, or no run of this content)."""
    if not reference_target:
        return None
    return reference_candidates(run, reference_target).first()


def stale_reference(run, reference_target: str):
    """A successful reference run of the same test case and run name but other content (or None).

    Used to say why there is no reference run: the reference ran an earlier (or later) version of the test
    case, and ``harness run`` of the reference target refreshes it.
    """
    from harness.models import Run

    return (Run.objects.filter(target__name=reference_target, testcase_id=run.testcase_id, name=run.name,
                               state__in=SUCCESS_STATES).exclude(testcase_hash=run.testcase_hash)
            .select_related("build").order_by("-finished", "-id").first())
