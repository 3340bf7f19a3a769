"""The efficiency pages: scaling studies and their efficiency over commits, timing breakdowns as stacked bars
over the commits of a target and side by side in compare, and flame graph data of one or two profiled runs.
The store is filled through the ORM; profiles are real folded-stack files in run folders."""
from __future__ import annotations

import re
from datetime import datetime, timedelta, timezone

from dashboard_data import FolderTestCase

from harness.analysis import scaling
from harness.store.models import Build, Machine, Run, Target
from harness.store.models import TestCase as Case

T0 = datetime(2026, 1, 1, tzinfo=timezone.utc)
#: stepping times of a strong scaling study on 1 and 2 cores at two commits: the second scales worse
TIMES = {"a" * 40: {1: 10.0, 2: 5.5}, "b" * 40: {1: 10.0, 2: 8.0}}
STACKS_A = "dem;main;integrate 30\ndem;main;pair_forces 50\ndem;main;neighbor_list 20\n"
STACKS_B = "dem;main;integrate 30\ndem;main;pair_forces 150\ndem;main;neighbor_list 20\n"


def breakdown(pair: float, neighbor: float, ranks: int = 1, spread: float = 0.0) -> dict:
    sections = {"pair": {"avg": pair}, "neighbor": {"avg": neighbor}, "other": {"avg": 0.1}}
    if spread:
        sections["pair"].update(min=pair - spread, max=pair + spread)
    return {"sections": sections, "total": pair + neighbor + 0.1, "ranks": ranks,
            "imbalance": (pair + spread) / pair if spread else None, "imbalance_of": "pair time" if spread else ""}


class EfficiencyPagesTest(FolderTestCase):
    folder_prefix = "efficiency-pages-"

    @classmethod
    def setUpTestData(cls):
        machine = Machine.objects.create(name="ws")
        cls.target = target = Target.objects.create(name="lig")
        cls.case = case = Case.objects.create(path="liggghts/settling")
        cls.builds = []
        for i, commit in enumerate(TIMES):
            build = Build.objects.create(target=target, machine=machine, revision="HEAD", commit=commit,
                                         definition_hash="d", status="complete", current=(i == 1),
                                         committed_at=T0 + timedelta(days=i))
            cls.builds.append(build)
            for point in scaling.expand({"name": "scaling", "script": "in.settling", "scaling": {"cores": [1, 2]}}):
                cores = point["scaling_point"]["cores"]
                Run.objects.create(machine=machine, target=target, build=build, testcase=case, name=point["name"],
                                   state="post_processed", config=point, stepping_time=TIMES[commit][cores],
                                   breakdown=breakdown(TIMES[commit][cores] * 0.8, 0.5, cores, 0.3 * (cores - 1)))
        # a profiled run per commit, with its folded stacks in its run folder
        cls.profiled = []
        for build, stacks, pair in ((cls.builds[0], STACKS_A, 1.0), (cls.builds[1], STACKS_B, 3.0)):
            folder = cls.root / f"run-{build.commit[:4]}"
            folder.mkdir()
            (folder / "profile.folded").write_text(stacks)
            cls.profiled.append(Run.objects.create(
                machine=machine, target=target, build=build, testcase=case, name="serial", state="post_processed",
                config={"name": "serial"}, stepping_time=pair + 0.6, breakdown=breakdown(pair, 0.5),
                folder=str(folder), profile="profile.folded"))

    def test_scaling_page_shows_the_figures_and_the_efficiency_over_commits(self):
        html = self.client.get("/scaling/").content.decode()
        self.assertIn("lig on ws: liggghts/settling/scaling", html)
        table = html.split("scaling-table")[1].split("</table>")[0]
        cells = [re.sub(r"<[^>]+>", "", c).strip() for c in re.findall(r"<td[^>]*>(.*?)</td>", table, re.S)]
        # current build (commit b): T(1) = 10, T(2) = 8: S = 1.25, E = 62 %, e = (1/1.25 - 1/2)/(1/2) = 0.6
        self.assertEqual(cells[8:13], ["2", "8.0000", "1.250", "62 %", "0.600"])
        history = html.split("scaling-history")[1].split("</table>")[0]
        rows = re.findall(r"<code>(\w+)</code>.*?<td class=\"num\">(\d+) %", history, re.S)
        # commit a: S = 10/5.5 = 1.818, E = 91 %; commit b scales worse at the same one-core time
        self.assertEqual(rows, [("a" * 10, "91"), ("b" * 10, "62")])
        # 62 % after 91 %: more than 10 % worse, at the same one-core time
        self.assertEqual(history.count("scales worse</span>"), 1)
        self.assertLess(history.index("b" * 10), history.index("scales worse</span>"))

    def test_scaling_plots_and_one_revisions_studies(self):
        current = self.builds[1]
        data = self.client.get(f"/scaling/{current.pk}/{self.case.path}/scaling.json").json()
        speedup, efficiency = data["plots"]
        self.assertEqual((speedup["x"], speedup["xticks"]), ([0, 1], ["1", "2"]))  # one tick per core count
        self.assertEqual(speedup["series"][0]["values"], [1.0, 1.25])
        self.assertEqual(speedup["series"][1]["values"], [1.0, 2.0])
        self.assertEqual(efficiency["xticks"], ["a" * 10, "b" * 10])
        self.assertAlmostEqual(efficiency["series"][0]["values"][0], 10 / 5.5 / 2)
        self.assertEqual(efficiency["ylimits"], [0.0, 1.05])                       # fractions: near [0, 1]
        self.assertEqual(self.client.get(f"/scaling/{current.pk}/{self.case.path}/nope.json").status_code, 404)
        older = self.client.get(f"/scaling/?build={self.builds[0].pk}").content.decode()
        table = older.split("scaling-table")[1].split("</table>")[0]
        self.assertIn("<td class=\"num\">1.818</td>", table)
        self.assertIn(f'href="/scaling/?build={self.builds[0].pk}"', self.client.get("/scaling/").content.decode())

    def test_a_serial_fraction_beyond_the_axis_is_drawn_at_its_top_with_its_value_on_hover(self):
        """A point slower on 2 cores than on 1 (speedup 0.1): Karp-Flatt e = 19; the efficiency axis stays
        [0, 1.5] and e is drawn at 1.5, its value 19 on hover."""
        current = self.builds[1]
        Run.objects.filter(build=current, name__endswith="cores=2").update(stepping_time=100.0)
        efficiency = self.client.get(f"/scaling/{current.pk}/{self.case.path}/scaling.json").json()["plots"][1]
        serial = efficiency["series"][1]
        self.assertEqual(efficiency["ylimits"], [0.0, 1.5])
        self.assertEqual(serial["values"][1], 1.5)
        self.assertAlmostEqual(serial["hover"][1], (1 / 0.1 - 1 / 2) / (1 - 1 / 2))

    def test_breakdown_over_commits_draws_one_bar_per_commit_on_one_scale(self):
        html = self.client.get(f"/breakdown/{self.target.pk}/{self.case.path}/").content.decode()
        serial = html.split("<h2>serial</h2>")[1].split("</section>")[0]
        widths = [float(w) for w in re.findall(r'class="stack" style="width: ([\d.]+)%"', serial)]
        # totals 1.0 + 0.5 + 0.1 = 1.6 s and 3.6 s: the older commit's bar is 1.6/3.6 of the newer
        self.assertEqual(len(widths), 2)
        self.assertAlmostEqual(widths[0], 100 * 1.6 / 3.6, places=1)
        self.assertEqual(widths[1], 100.0)
        self.assertIn('title="pair: 3.0000 s"', serial)
        self.assertIn(f'href="/runs/{self.profiled[1].pk}/profile/"', serial)
        self.assertIn(f'href="/profiles/diff/?run={self.profiled[0].pk},{self.profiled[1].pk}"', serial)
        history = self.client.get(f"/history/{self.target.pk}/{self.case.path}/").content.decode()
        self.assertIn(f'href="/breakdown/{self.target.pk}/{self.case.path}/"', history)

    def test_run_and_compare_pages_show_min_avg_max_imbalance_and_the_differential_link(self):
        two = Run.objects.get(build=self.builds[1], name="scaling@cores=2")
        html = self.client.get(f"/runs/{two.pk}/").content.decode()
        table = html.split("breakdown-table")[1].split("</table>")[0]
        self.assertIn("6.4000", table)                       # pair avg 0.8 * 8 s
        self.assertIn("6.1000-6.7000", table)                # min-max over the ranks
        self.assertIn("1.05 <span class=\"note\">pair time</span>", table)  # 6.7 / 6.4
        a, b = self.profiled
        compare = self.client.get(f"/compare/?run={a.pk}&run={b.pk}").content.decode()
        self.assertIn(f'href="/profiles/diff/?run={a.pk},{b.pk}"', compare)
        self.assertEqual(compare.split("breakdown-table")[1].count("<tr><td>"), 2)

    def test_flame_graph_data_and_the_differential_deltas(self):
        a, b = self.profiled
        tree = self.client.get(f"/runs/{a.pk}/profile.json").json()
        self.assertEqual(tree["value"], 100)
        main = tree["children"][0]["children"][0]
        self.assertEqual({c["name"]: c["value"] for c in main["children"]},
                         {"integrate": 30, "pair_forces": 50, "neighbor_list": 20})
        diff = self.client.get(f"/profiles/diff.json?run={a.pk},{b.pk}").json()
        self.assertEqual(diff["value"], 200)
        main = diff["children"][0]["children"][0]
        deltas = {c["name"]: c["delta"] for c in main["children"]}
        # A scaled to B's 200 samples: integrate 60 -> 30, pair 100 -> 150, neighbor 40 -> 20
        self.assertEqual(deltas, {"integrate": -30.0, "pair_forces": 50.0, "neighbor_list": -20.0})
        self.assertEqual(main["delta"], 0.0)  # self deltas: main has no samples of its own
        page = self.client.get(f"/profiles/diff/?run={a.pk},{b.pk}").content.decode()
        first = page.split("share grew most")[1].split("</tr>")[1]
        # pair_forces: 50 % of A's samples, 75 % of B's
        self.assertIn("pair_forces", first)
        self.assertIn("50.0 %", first) and self.assertIn("75.0 %", first) and self.assertIn("+25.0 %", first)
        self.assertIn("vendor/d3-flame-graph/d3-flamegraph.min.js", page)
        unprofiled = Run.objects.get(build=self.builds[0], name="scaling@cores=1")
        self.assertEqual(self.client.get(f"/runs/{unprofiled.pk}/profile.json").status_code, 404)
        self.assertIn("has no profile", self.client.get(f"/runs/{unprofiled.pk}/profile/").content.decode())
        self.assertEqual(self.client.get(f"/profiles/diff.json?run={a.pk}").status_code, 400)

    def test_efficiency_pages_take_as_many_queries_with_ten_thousand_more_runs(self):
        """Each page's SQL queries are a fixed set, whatever the store holds: 10,000 more runs of the same target
        and build add rows to what the queries return, never a query per run. (Their time with 10,000 runs is a
        benchmark's, `python benchmarks/dashboard_pages.py`: a timed test fails on a loaded machine.)"""
        from dashboard_data import add_bulk_runs
        from django.db import connection
        from django.test.utils import CaptureQueriesContext

        pages = ["/scaling/", f"/breakdown/{self.target.pk}/{self.case.path}/", f"/runs/{self.profiled[1].pk}/profile/",
                 f"/profiles/diff/?run={self.profiled[0].pk},{self.profiled[1].pk}"]

        def queries() -> dict:
            counts = {}
            for url in pages:
                with CaptureQueriesContext(connection) as captured:
                    response = self.client.get(url)
                self.assertEqual(response.status_code, 200, url)
                counts[url] = len(captured.captured_queries)
            return counts

        before = queries()
        add_bulk_runs(10_000, Machine.objects.get(name="ws"), self.target, self.builds[1])
        self.assertEqual(queries(), before)
