"""One rules layer: the Python predicates of harness.store.rules and their SQL forms in harness.store.queries agree, and
``harness list -q`` (``RunQuerySet.failing``), the "failing since" streaks and ``harness check``'s verdicts
name the same failing runs, on a store with every kind of reviewer override."""
from __future__ import annotations

from datetime import datetime, timedelta, timezone

from django.contrib.auth import get_user_model
from django.test import TestCase

from harness.analysis.coverage import covered_runs
from harness.analysis.verdicts import stored_verdict
from harness.store import rules
from harness.store.models import (
    Build,
    ConsistencyResult,
    Machine,
    Override,
    Run,
    Target,
)
from harness.store.models import TestCase as Case

T0 = datetime(2026, 3, 1, tzinfo=timezone.utc)


class RulesAgreeTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        machine = Machine.objects.create(name="ws1")
        reference = Target.objects.create(name="ref", definition={})
        target = Target.objects.create(name="dem", definition={}, reference=reference)
        case = Case.objects.create(path="contact/impact")
        old, new = (Build.objects.create(target=target, machine=machine, revision="HEAD", commit=c * 40,
                                         definition_hash="d", status="complete", committed_at=T0 + timedelta(days=i),
                                         current=i == 1) for i, c in enumerate("12"))
        ref_build = Build.objects.create(target=reference, machine=machine, revision="v1", commit="f" * 40,
                                         definition_hash="d", status="complete", committed_at=T0, current=True)
        ref_run = Run.objects.create(machine=machine, target=reference, build=ref_build, testcase=case, name="x",
                                     state="consistency_checked", consistency="perfect", finished=T0)
        user = get_user_model().objects.create_user("reviewer", password="pw-for-tests-only")
        cls.runs = {}

        def run(name, build=new, bad=(), overrides=(), **fields):
            made = Run.objects.create(machine=machine, target=target, build=build, testcase=case, name=name,
                                      testcase_hash="ab" * 32, **{"finished": T0, **fields})
            for series, quantity in bad:
                ConsistencyResult.objects.create(run=made, reference_run=ref_run, series_kind="thermo",
                                                 series_name=series, quantity=quantity, value=0.2,
                                                 level="inconsistent", epsilon=1e-5)
            ConsistencyResult.objects.create(run=made, reference_run=ref_run, series_kind="thermo",
                                             series_name="thermo", quantity="atoms", value=1.0, level="perfect")
            for quantity in overrides:
                Override.objects.create(run=made, quantity=quantity, user=user, reason="reviewed")
            cls.runs.setdefault(name, []).append(made)
            return made

        failed = {"state": "failed", "failure_reason": "exit_code"}
        inconsistent = {"state": "consistency_checked", "consistency": "inconsistent"}
        two_bad = (("thermo", "ke"), ("torqueZ", "torque"))
        # the history of each run configuration: an older build's run first (outdated, as make_current leaves it)
        for name in ("failed", "failed-accepted", "half-overruled"):
            run(name, build=old, **{**failed, "state": "outdated"})
        run("failed", **failed)
        run("failed-accepted", overrides=[rules.WHOLE_RUN], **failed)
        # a failed run can only be accepted as a whole: a quantity's override left from an earlier check is not
        run("failed-quantity-override", overrides=["ke"], bad=[("thermo", "ke")], **failed,
            consistency="inconsistent")
        run("half-overruled", bad=two_bad, overrides=["ke"], **inconsistent)
        run("all-overruled", bad=two_bad, overrides=["ke", "torqueZ:torque"], **inconsistent)
        run("dot-overruled", bad=two_bad, overrides=["thermo.ke", "torqueZ.torque"], **inconsistent)
        run("whole-overruled", bad=two_bad, overrides=[rules.WHOLE_RUN], **inconsistent)
        run("other-series-named", bad=[("torqueZ", "torque")], overrides=["thermo:torque"], **inconsistent)
        run("consistent", state="consistency_checked", consistency="perfect")
        run("not-checked", state="post_processed")
        run("not-executed", state="not_executed", finished=None)

    def test_the_sql_accepted_annotation_is_the_python_rule(self):
        annotated = {r.pk: r.accepted for r in Run.objects.with_accepted()}
        checked = 0
        for run in Run.objects.prefetch_related("overrides", "consistency_results"):
            overrides = {o.quantity: o.reason for o in run.overrides.all()}
            results = [(r.series_name, r.quantity, r.level) for r in run.consistency_results.all()]
            assert annotated[run.pk] == rules.is_accepted(run.state, run.consistency, overrides, results), run.name
            checked += 1
        assert checked == len(annotated) > 10
        accepted = set(Run.objects.accepted().values_list("name", flat=True))
        assert accepted == {"failed-accepted", "all-overruled", "dot-overruled", "whole-overruled"}

    def test_list_failing_since_and_check_name_the_same_failing_runs(self):
        current = list(covered_runs())
        by_check = {r.name for r in current if stored_verdict(r).status == "failed" and r.state != "not_executed"}
        by_list = set(Run.objects.current().failing().values_list("name", flat=True))  # `harness list -q`
        with_accepted = list(Run.objects.current().with_accepted())
        by_since = {r.name for r in with_accepted if r.pk in Run.objects.failing_since(with_accepted)}
        by_predicate = {r.name for r in with_accepted if rules.is_failing(r)}
        assert by_check == by_list == by_since == by_predicate == {
            "failed", "failed-quantity-override", "half-overruled", "other-series-named"}
        # the runs not executed are the gate's other failures, not failing runs
        assert {r.name for r in current if stored_verdict(r).status == "failed"} - by_check == {"not-executed"}

    def test_an_outdated_run_that_failed_for_its_own_build_is_failing_in_both_forms(self):
        older = Run.objects.filter(build__current=False).with_accepted()
        assert {r.name for r in older if rules.is_failing(r)} == set(
            older.failing().values_list("name", flat=True)) == {"failed", "failed-accepted", "half-overruled"}

    def test_reading_the_current_build_writes_nothing(self):
        from django.db import connection
        from django.test.utils import CaptureQueriesContext

        from harness.execution.builds import current_build

        with CaptureQueriesContext(connection) as queries:
            build = current_build("dem", "ws1")
        assert build.commit == "2" * 40
        assert [q["sql"] for q in queries.captured_queries] and all(
            q["sql"].lstrip().upper().startswith("SELECT") for q in queries.captured_queries)
