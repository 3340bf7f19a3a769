""""Failing since": on a test case's run lists and the run page, the first commit of the target's history on
that machine since which the run has failed or been inconsistent without interruption."""
from __future__ import annotations

import re
from datetime import datetime, timedelta, timezone

from django.contrib.auth import get_user_model
from django.db import connection
from django.test import TestCase
from django.test.utils import CaptureQueriesContext

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


class FailingSinceTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        ws1, ws2 = Machine.objects.create(name="ws1"), Machine.objects.create(name="ws2")
        cls.ws1 = ws1
        cls.target = Target.objects.create(name="dem", definition={})
        cls.case = Case.objects.create(path="contact/impact")
        # five commits, the last current; older runs are outdated, as `harness` leaves them
        cls.builds = [Build.objects.create(target=cls.target, machine=ws1, revision=f"HEAD~{4 - i}",
                                           commit=f"{i + 1}" * 40, definition_hash="d", status="complete",
                                           committed_at=T0 + timedelta(days=i), current=i == 4)
                      for i in range(5)]

        ref_target = Target.objects.create(name="dem-ref", definition={})
        ref_build = Build.objects.create(target=ref_target, machine=ws1, revision="v1", commit="f" * 40,
                                         definition_hash="d", status="complete", committed_at=T0, current=True)
        reference = Run.objects.create(machine=ws1, target=ref_target, build=ref_build, testcase=cls.case,
                                       name="serial", testcase_hash="ab" * 32, state="post_processed")

        def run(i, name, outcome, machine=ws1, **kw):
            build = cls.builds[i] if machine == ws1 else Build.objects.get_or_create(
                target=cls.target, machine=machine, commit=cls.builds[i].commit, definition_hash="d",
                defaults={"revision": "HEAD", "status": "complete", "committed_at": cls.builds[i].committed_at,
                          "current": True})[0]
            fields = {"good": {"state": "consistency_checked", "consistency": "perfect", "finished": T0},
                      "failed": {"state": "failed", "failure_reason": "exit_code", "finished": T0},
                      "inconsistent": {"state": "consistency_checked", "consistency": "inconsistent",
                                       "finished": T0},
                      "not_run": {"state": "not_executed"}}[outcome]
            if i < 4 and outcome != "not_run" and machine == ws1:
                fields["state"] = "outdated"  # what harness.execution.builds.make_current leaves of an older build's run
            made = Run.objects.create(machine=machine, target=cls.target, build=build, testcase=cls.case,
                                      name=name, testcase_hash="ab" * 32, **fields, **kw)
            if outcome == "inconsistent":  # its bad quantity (without one, nothing is left to overrule)
                ConsistencyResult.objects.create(run=made, reference_run=reference, series_kind="thermo", series_name="thermo",
                                                 quantity="ke", value=0.2, level="inconsistent", epsilon=1e-5)
            return made

        cls.serial = [run(0, "serial", "good"), run(1, "serial", "failed"), run(2, "serial", "not_run"),
                      run(3, "serial", "inconsistent"), run(4, "serial", "failed")]
        cls.mpi = [run(0, "mpi", "failed"), run(1, "mpi", "inconsistent"), run(4, "mpi", "failed")]
        cls.fine = run(4, "fine", "good")
        cls.elsewhere = run(4, "serial", "failed", machine=ws2)  # another machine's history
        cls.user = get_user_model().objects.create_user("reviewer", password="pw-for-tests-only")

    def since(self, run):
        return Run.objects.failing_since(list(Run.objects.filter(pk=run.pk).with_accepted()))

    def test_the_streak_passes_over_runs_not_executed_and_stops_at_a_success(self):
        found = self.since(self.serial[4])[self.serial[4].pk]
        assert found["commit"] == "2" * 40 and found["run_id"] == self.serial[1].pk
        assert found["builds"] == 3 and found["first"] is False  # commits 2, 4 and 5; 3 did not run
        assert self.since(self.serial[3])[self.serial[3].pk]["commit"] == "2" * 40
        assert self.since(self.serial[1])[self.serial[1].pk]["builds"] == 1
        assert self.since(self.serial[0]) == {} and self.since(self.fine) == {}

    def test_a_streak_from_the_first_recorded_build_says_so(self):
        found = self.since(self.mpi[2])[self.mpi[2].pk]
        assert found["commit"] == "1" * 40 and found["builds"] == 3 and found["first"] is True

    def test_other_machines_do_not_count(self):
        found = self.since(self.elsewhere)[self.elsewhere.pk]
        assert found["commit"] == "5" * 40 and found["builds"] == 1

    def test_an_overruled_run_interrupts(self):
        Override.objects.create(run=self.serial[3], user=self.user, reason="known: new damping")
        found = self.since(self.serial[4])[self.serial[4].pk]
        assert found["commit"] == "5" * 40 and found["builds"] == 1

    def test_run_page(self):
        html = self.client.get(f"/runs/{self.serial[4].pk}/").content.decode()
        dd = html[html.index("<dt>failing since</dt>"):]
        dd = dd[:dd.index("</dd>")]
        assert f'href="/runs/{self.serial[1].pk}/"><code>2222222222</code></a>' in dd
        assert "3 builds" in dd and "2026-03-02" in dd and "from the first recorded" not in dd
        assert "failing since" not in self.client.get(f"/runs/{self.fine.pk}/").content.decode()
        own = self.client.get(f"/runs/{self.serial[1].pk}/").content.decode()
        assert "1 build" in own and "(this run)" in own

    def test_test_case_run_lists(self):
        html = self.client.get("/testcases/contact/impact/").content.decode()
        assert "<th>failing since</th>" in html
        rows = {int(m.group(1)): m.group(2) for m in re.finditer(
            r'name="run" value="(\d+)".*?<td class="failing-since">(.*?)</td>', html, re.S)}
        assert "2222222222" in rows[self.serial[4].pk] and "3 builds" in rows[self.serial[4].pk]
        assert "1111111111" in rows[self.mpi[2].pk] and "from the first recorded" in rows[self.mpi[2].pk]
        assert rows[self.fine.pk] == "" and rows[self.serial[0].pk] == ""
        folder = self.client.get(f"/m/{self.ws1.pk}/t/{self.target.pk}/f/contact/impact/").content.decode()
        assert "<th>failing since</th>" in folder and "2222222222" in folder

    def test_one_query_for_a_page_of_runs(self):
        def count(url):
            with CaptureQueriesContext(connection) as ctx:
                assert self.client.get(url).status_code == 200
            return len(ctx.captured_queries)

        before = count("/testcases/contact/impact/")
        for i in range(5):  # more failing runs, with histories of their own
            Run.objects.create(machine=self.ws1, target=self.target, build=self.builds[4], testcase=self.case,
                               name=f"extra{i}", state="failed", failure_reason="timeout")
        assert count("/testcases/contact/impact/") == before
