"""The build comparison page: what `harness compare A B` prints, from a form of the store's builds."""
from __future__ import annotations

import html as htmllib
import re

from dashboard_data import T0, StoreTestCase, kinetic_energy, thesis_consistency
from django.test import TestCase

from harness.analysis.compare import compare_builds, rows, summary
from harness.store.models import Build


def cells(html: str) -> list[list[str]]:
    """Text of the comparison table's body cells, row by row."""
    body = html.split('<table class="build-comparison">', 1)[1].split("</table>", 1)[0].split("<tbody>", 1)[1]
    return [[htmllib.unescape(re.sub(r"<[^>]+>", "", c)).strip() for c in re.findall(r"<td[^>]*>(.*?)</td>", r, re.S)]
            for r in re.findall(r"<tr[^>]*>(.*?)</tr>", body, re.S)]


class CompareBuildsTest(StoreTestCase):
    folder_prefix = "compare-builds-"

    @classmethod
    def setUpTestData(cls):
        from harness.store.models import Run

        super().setUpTestData()
        # finished runs: an outdated run of an older build is, for that build, what it ended as
        Run.objects.exclude(state="not_executed").update(finished=T0)
        cls.old = Build.objects.get(commit="b" * 40)
        cls.new = cls.s["new_build"]

    def page(self, a, b):
        response = self.client.get(f"/builds/compare/?a={a.pk}&b={b.pk}")
        self.assertEqual(response.status_code, 200)
        return response.content.decode()

    def test_the_form_offers_every_complete_build(self):
        html = self.client.get("/builds/compare/").content.decode()
        for build in Build.objects.all():
            self.assertIn(f'<option value="{build.pk}"', html)
        self.assertIn('<optgroup label="dem-master on ws1">', html)

    def test_without_a_choice_the_reference_is_compared_with_the_current_build(self):
        """Never A = B: dem-v1's current build (the reference) against dem-master's current build."""
        html = self.client.get("/builds/compare/").content.decode()
        reference = Build.objects.get(commit="a" * 40)
        self.assertIn("Chosen for you", html)
        a = html.split('id="build-a"', 1)[1].split("</select>", 1)[0]
        b = html.split('id="build-b"', 1)[1].split("</select>", 1)[0]
        self.assertIn(f'<option value="{reference.pk}" selected>', a)
        self.assertIn(f'<option value="{self.new.pk}" selected>', b)
        self.assertEqual(cells(html), cells(self.page(reference, self.new)))

    def test_rows_are_what_harness_compare_prints(self):
        html = self.page(self.old, self.new)
        expected = compare_builds(self.old, self.new, "ws1", "dem-master@HEAD~1 (bbbbbbb)", "dem-master@ccccccc")
        table = cells(html)
        self.assertEqual([row[:8] for row in table], [[str(c).strip() for c in r] for r in rows(expected)[1:]])
        self.assertIn(htmllib.escape(summary(expected)), html)
        # the drifted impact: B against A by the thesis' equations, computed independently
        c, _eps, first_bad, level = thesis_consistency(kinetic_energy(8e-5), kinetic_energy())
        hertz = next(r for r in table if r[0] == "contact_models/hertz/impact")
        self.assertEqual((hertz[2], hertz[3], hertz[6]), ("inconsistent", f"{c:.4g}", f"{first_bad:g}"))
        self.assertIn("failed", html.split('class="verdict', 1)[1][:60])
        # stepping time is not stored in this store: no ratio, no geometric mean
        self.assertIn('<strong id="time-ratio">-</strong>', html)

    def test_each_pair_links_to_its_two_runs_and_plots(self):
        html = self.page(self.old, self.new)
        link = f'/compare/?run={self.s["older"].pk}&amp;run={self.s["inconsistent"].pk}'
        self.assertIn(f'<a class="plots-link" href="{link}">plots</a>', html)
        compared = self.client.get(htmllib.unescape(link))
        self.assertEqual(compared.status_code, 200)

    def test_stepping_time_ratio_and_its_geometric_mean(self):
        from harness.store.models import Run

        Run.objects.filter(pk=self.s["older"].pk).update(stepping_time=2.0)
        Run.objects.filter(pk=self.s["inconsistent"].pk).update(stepping_time=1.0)
        html = self.page(self.old, self.new)
        hertz = next(r for r in cells(html) if r[0] == "contact_models/hertz/impact")
        self.assertEqual(hertz[7], "0.500")
        self.assertIn('<strong id="time-ratio">0.500</strong>', html)

    def test_bad_choices_are_400_or_404(self):
        self.assertEqual(self.client.get(f"/builds/compare/?a={self.old.pk}").status_code, 400)
        self.assertEqual(self.client.get("/builds/compare/?a=1&b=x").status_code, 400)
        self.assertEqual(self.client.get(f"/builds/compare/?a={self.old.pk}&b=999999").status_code, 404)


class CompareBuildsQueriesTest(TestCase):
    """A comparison reads plain rows and the series of its scored pairs together: the number of queries does
    not grow with the pairs, and the scores are those of the two runs' model objects."""

    def test_queries_do_not_grow_with_scored_pairs(self):
        from dashboard_data import add_series
        from django.db import connection
        from django.test.utils import CaptureQueriesContext

        from harness.analysis.compare import compare_pair
        from harness.store.models import Machine, Run, Target
        from harness.store.models import TestCase as Case

        machine, target = Machine.objects.create(name="ws"), Target.objects.create(name="dem")
        builds = [Build.objects.create(target=target, machine=machine, revision="HEAD", commit=c * 40,
                                       definition_hash="d", status="complete", committed_at=T0) for c in "ab"]

        def add_pairs(start: int, count: int):
            for i in range(start, start + count):
                case = Case.objects.create(path=f"cases/case{i}")
                for build, shift in zip(builds, (0.0, 1e-4 * (i % 2))):  # every other pair drifts
                    add_series(Run.objects.create(machine=machine, target=target, build=build, testcase=case,
                                                  name="serial", state="post_processed", finished=T0,
                                                  stepping_time=1.0 + shift), kinetic_energy(shift))

        def queries() -> int:
            with CaptureQueriesContext(connection) as ctx:
                comparison = compare_builds(builds[0], builds[1], "ws", "A", "B")
            return len(ctx.captured_queries), comparison

        add_pairs(0, 2)
        few, _ = queries()
        add_pairs(2, 6)
        many, comparison = queries()
        self.assertEqual(few, many)
        self.assertEqual(comparison.counts()["inconsistent"], 4)
        self.assertEqual(comparison.counts()["consistent"], 4)
        # the same scores as from the model objects, pair by pair
        for pair in comparison.pairs:
            a, b = Run.objects.get(pk=pair.a.pk), Run.objects.get(pk=pair.b.pk)
            self.assertEqual([q.__dict__ for q in compare_pair(a, b).quantities],
                             [q.__dict__ for q in pair.quantities])
