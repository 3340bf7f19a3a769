"""Every dashboard view through Django's test client, content asserted; query counts fixed."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from dashboard_data import StoreTestCase, add_bulk_runs
from django.db import connection
from django.test import Client
from django.test.utils import CaptureQueriesContext

from harness.store.models import Override, Run

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


class DashboardTest(StoreTestCase):
    folder_prefix = "dashboard-runs-"

    def get(self, url, **kw):
        response = self.client.get(url, **kw)
        self.assertEqual(response.status_code, 200, url)
        return response

    def queries(self, url) -> int:
        with CaptureQueriesContext(connection) as ctx:
            self.get(url)
        return len(ctx.captured_queries)

    def folder_url(self, path="", **params):
        s = self.s
        base = f"/m/{s['ws1'].pk}/t/{s['master'].pk}/" + (f"f/{path}/" if path else "")
        return base + ("?" + "&".join(f"{k}={v}" for k, v in params.items()) if params else "")


def target_rows(html: str) -> dict[str, str]:
    """The overview's rows by target name: {target: the row's HTML}, in page order."""
    rows = re.findall(r'<tr class="target verdict-[a-z_]+">(.*?)</tr>', html, re.S)
    return {re.search(r'/t/\d+/\?mode=[a-z]+[^"]*">([^<]+)</a>', row).group(1): row for row in rows}


def cells(row: str) -> list[str]:
    """The text of a table row's cells, tags left out."""
    return [" ".join(re.sub(r"<[^>]+>", " ", c).split()) for c in re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]


class OverviewTest(DashboardTest):
    def test_a_run_without_a_reference_run_is_counted_as_such_not_as_not_checked(self):
        """A checked run whose reference target has no run of its content: "no reference run", the glossary's
        level, in the overview's consistency cell and bar, and a category of its own in the folder filter."""
        Run.objects.filter(pk=self.s["good"].pk).update(consistency="no_reference")
        master = cells(target_rows(self.get("/").content.decode())["dem-master"])
        self.assertEqual(master[6], "1 inconsistent 2 not checked 1 no reference run")
        html = self.get(self.folder_url(mode="consistency", show="no_reference")).content.decode()
        self.assertIn("no reference run", html)
        self.assertEqual(list(Run.objects.in_category("no_reference").values_list("pk", flat=True)),
                         [self.s["good"].pk])
        self.assertNotIn(self.s["good"].pk, Run.objects.in_category("not_checked").values_list("pk", flat=True))

    def test_a_row_per_target_failing_first_with_the_check_verdict(self):
        html = self.get("/").content.decode()
        self.assertIn("machine ws1", html)
        rows = target_rows(html)
        self.assertEqual(list(rows), ["dem-master", "dem-v1"])  # failing first
        master = cells(rows["dem-master"])
        # verdict, target, commit, passed, failed, not run (+ runs of older builds), consistency, lowest C
        # the run never executed is a failure of the gate, as in harness check (harness.analysis.coverage)
        self.assertEqual(master[:6], ["failed", "dem-master vs dem-v1", "cccccccccc HEAD", "1", "3", "0 +1 older"])
        self.assertEqual(master[6], "1 inconsistent 2 not checked 1 consistent")  # counts that are not 0, worst first
        self.assertEqual(master[7], f"{self.s['c']:.4f}")
        self.assertEqual(master[9], "5 Jan 12:00")
        self.assertIn('title="faster neighbor list"', rows["dem-master"])  # the commit's subject on hover
        self.assertEqual(cells(rows["dem-v1"])[:6], ["passed", "dem-v1", "aaaaaaaaaa v1", "1", "0", "0"])
        # both modes show the same verdicts
        self.assertEqual([cells(r)[0] for r in target_rows(self.get("/?mode=consistency").content.decode()).values()],
                         ["failed", "passed"])

    def test_the_overview_verdict_is_the_one_harness_check_gives(self):
        """Per target, the passed / failed / not run counts equal the stored verdicts of harness.analysis.verdicts (the
        verdicts `harness check` writes), also after a reviewer overrules a failure and an inconsistency."""
        from harness.analysis.coverage import covered_runs
        from harness.analysis.verdicts import stored_verdict
        from harness.store.models import Override

        def from_check():
            out = {}
            for run in covered_runs():
                status = {"skipped": "not run"}.get(stored_verdict(run).status, stored_verdict(run).status)
                counts = out.setdefault(run.target.name, {"passed": 0, "failed": 0, "not run": 0})
                counts[status] += 1
            return out

        def from_page():
            out = {}
            for name, row in target_rows(self.get("/").content.decode()).items():
                c = cells(row)
                out[name] = {"passed": int(c[3]), "failed": int(c[4]), "not run": int(c[5].split()[0])}
            return out

        self.assertEqual(from_page(), from_check())
        Override.objects.create(run=self.s["failed"], user=self.s["user"], quantity="", reason="known crash")
        Override.objects.create(run=self.s["inconsistent"], user=self.s["user"], quantity="ke", reason="new damping")
        self.assertEqual(from_page(), from_check())
        # overruled: the failure and the inconsistency pass; the run never executed still fails
        self.assertEqual(from_page()["dem-master"], {"passed": 3, "failed": 1, "not run": 0})
        self.assertEqual(cells(target_rows(self.get("/").content.decode())["dem-master"])[0], "failed")
        Run.objects.filter(pk=self.s["not_run"].pk).update(state="outdated")
        self.assertEqual(from_page(), from_check())
        self.assertEqual(from_page()["dem-master"], {"passed": 3, "failed": 0, "not run": 1})
        self.assertEqual(cells(target_rows(self.get("/").content.decode())["dem-master"])[0], "passed")

    def test_commit_links_to_the_repository_web_view(self):
        from harness.store.models import Target

        master = self.s["master"]
        Target.objects.filter(pk=master.pk).update(
            definition={**master.definition, "commit_url": "https://example.org/dem/commit/{commit}"})
        row = target_rows(self.get("/").content.decode())["dem-master"]
        self.assertIn(f'<a class="web" href="https://example.org/dem/commit/{"c" * 40}"', row)
        self.assertIn(f'<a href="/commits/dem-master/{"c" * 40}/?machine=ws1" title="faster neighbor list">', row)

    def test_stepping_time_change_against_the_build_before(self):
        """The current master build against the older one, paired by test case and run name: the geometric
        mean of the ratios (one pair here: 0.6 s / 0.8 s, 25 % faster)."""
        Run.objects.filter(pk=self.s["inconsistent"].pk).update(stepping_time=0.6)
        Run.objects.filter(pk=self.s["older"].pk).update(stepping_time=0.8)
        row = target_rows(self.get("/").content.decode())["dem-master"]
        self.assertEqual(cells(row)[8], "-25 %")
        self.assertIn('class="change faster"', row)
        self.assertIn("over 1 run shared with the build before (bbbbbbbbbb)", row)
        # repeated runs (harness run --repeat) that spread by 40 %: a 25 % change is shown with it, not marked
        Run.objects.filter(pk=self.s["inconsistent"].pk).update(
            timing={**self.s["inconsistent"].timing, "stepping_repeats": [0.5, 0.6, 0.74]})
        row = target_rows(self.get("/").content.decode())["dem-master"]
        self.assertEqual(cells(row)[8], "-25 % &plusmn;40 %")
        self.assertIn('class="change same"', row)
        Run.objects.filter(pk=self.s["inconsistent"].pk).update(timing=self.s["inconsistent"].timing)
        # a change under 10 % is shown, not marked
        Run.objects.filter(pk=self.s["older"].pk).update(stepping_time=0.63)
        row = target_rows(self.get("/").content.decode())["dem-master"]
        self.assertEqual(cells(row)[8], "-5 %")
        self.assertIn('class="change same"', row)

    def test_the_commit_page_says_what_the_commit_changed(self):
        """dem-master at cccc against the commit before (bbbb): the drifted impact is inconsistent, two hooke
        runs and the settle run exist only now; the verdict is that of harness check."""
        s = self.s
        Run.objects.exclude(state="not_executed").update(finished=s["older"].started)
        html = self.get(f"/commits/dem-master/{'c' * 12}/?machine=ws1").content.decode()
        self.assertIn("dem-master at <code>cccccccccc</code>", html)
        self.assertIn("faster neighbor list", html)
        self.assertIn('<span class="target-verdict failed">failed</span>', html)
        self.assertIn("1 passed", html)
        self.assertIn(f'href="/commits/dem-master/{"b" * 40}/?machine=ws1"', html)  # the commit before
        self.assertIn('<li class="outcome inconsistent">1 inconsistent</li>', html)
        self.assertIn("contact_models/hertz/impact", html.split('<table class="build-comparison">')[1])
        # the first build has no commit before
        html = self.get(f"/commits/dem-master/{'b' * 40}/").content.decode()
        self.assertIn("none: this is the first build of dem-master on ws1", html)
        self.assertEqual(self.client.get("/commits/dem-master/ffff/").status_code, 404)
        # run lists link each run's build to its commit page
        self.assertIn(f'href="/commits/dem-master/{"c" * 40}/?machine=ws1"',
                      self.get(f"/testcases/{s['hertz'].path}/").content.decode())

    def test_words_carry_the_glossary_sentence_as_tooltip(self):
        from django.utils.html import escape

        from harness.report.glossary import ALL

        html = self.get(f"/testcases/{self.s['hertz'].path}/").content.decode()
        self.assertIn(f'title="{escape(ALL["version-consistency-checked"])}">version-consistency-checked<', html)
        self.assertIn(f'title="{escape(ALL["inconsistent"])}">inconsistent<', html)
        overview = self.get("/").content.decode()
        self.assertIn(f'<th class="num" title="{escape(ALL["C"])}">lowest C</th>', overview)

    def test_a_search_lists_the_runs_it_found(self):
        html = self.get("/?q=hooke").content.decode()
        self.assertIn("Runs found", html)
        listed = {int(i) for i in re.findall(r'name="run" value="(\d+)"', html)}
        self.assertEqual(listed, {self.s["failed"].pk, self.s["not_run"].pk})
        self.assertNotIn("Runs found", self.get("/").content.decode())

    def test_older_build_runs_are_named_when_the_current_build_has_none(self):
        from harness.store.models import Build

        Build.objects.filter(pk=self.s["new_build"].pk).update(current=False)
        Build.objects.filter(pk=self.s["older"].build_id).update(current=True)
        Run.objects.filter(build=self.s["older"].build).delete()
        html = self.get("/").content.decode()
        self.assertIn("Not counted: no run of the current build", html)
        self.assertIn("dem-master on ws1</a>: 4 runs of older builds; current build <code>bbbbbbbbbb</code> "
                      "has none yet", html)

    def test_bar_colors_say_whether_anything_failed(self):
        from harness.store.queries import Tally
        from webfrontend.templatetags.dashboard import bar_color, verdict

        def tally(ok, bad, not_run=0):
            return Tally("x", "x", counts={"successful": ok, "failed": bad, "not_executed": not_run})

        self.assertEqual(bar_color(tally(1, 3)), "red")      # 3 failures of 4: no calm blue
        self.assertEqual(bar_color(tally(9, 1)), "red")      # one failure is a failure
        self.assertEqual(bar_color(tally(2, 0, 1)), "grey")  # nothing failed, not all ran
        self.assertEqual(bar_color(tally(3, 0)), "green")    # 100 %
        self.assertEqual(bar_color(tally(0, 0)), "grey")     # nothing ran: no alarm, no success
        self.assertEqual([verdict(tally(1, 3)), verdict(tally(3, 0)), verdict(tally(2, 0, 1)), verdict(tally(0, 0))],
                         ["failing", "passing", "incomplete", "empty"])

    def test_query_count_does_not_grow_with_runs(self):
        before = self.queries("/")
        add_bulk_runs(200, self.s["ws1"], self.s["master"], self.s["new_build"])
        self.assertEqual(self.queries("/"), before)
        self.assertLessEqual(before, 7)
        html = self.get("/").content.decode()
        # 3 of every 4 bulk runs succeed: 150 passed besides the good settle run
        self.assertEqual(cells(target_rows(html)["dem-master"])[3], "151")

    def test_machine_selection(self):
        from harness.store.models import Machine

        other = Machine.objects.create(name="cluster7")
        add_bulk_runs(3, other, self.s["master"], self.s["new_build"])
        html = self.get("/").content.decode()
        self.assertIn("machine cluster7", html)
        self.assertIn("machine ws1", html)
        html = self.get(f"/?machine={other.pk}").content.decode()
        self.assertIn("machine cluster7", html)
        self.assertNotIn("machine ws1", html)

    def test_empty_store_says_how_to_fill_it(self):
        Run.objects.all().delete()
        self.assertIn("harness run", self.get("/").content.decode())


class FolderTest(DashboardTest):
    def test_subfolders_aggregate_counts_and_run_time(self):
        html = self.get(self.folder_url("contact_models")).content.decode()
        hertz = html[html.index(">hertz/<"):]
        hertz = hertz[:hertz.index("</tr>")]
        self.assertIn("1 successful", hertz)
        self.assertNotIn("outdated", hertz)  # the older build's run is not counted
        self.assertIn("1.1 s", hertz)
        hooke = html[html.index(">hooke/<"):]
        self.assertIn("1 failed", hooke[:hooke.index("</tr>")])
        self.assertIn("total run time 1.5 s", html)  # 1.1 + 0.4 (+ 0 for the run not executed)
        self.assertIn("current build on ws1: HEAD <code>cccccccccc</code>", html)

    def test_older_build_runs_stay_reachable(self):
        older = self.s["older"]
        html = self.get(self.folder_url("contact_models/hertz/impact")).content.decode()
        self.assertNotIn(f'value="{older.pk}"', html)  # the test case lists its current build's runs
        history = re.search(r'href="(/history/[^"]+)"', html).group(1).replace("&amp;", "&")
        self.assertIn(f'value="{older.pk}"', self.get(history).content.decode())
        page = self.get(f"/runs/{older.pk}/").content.decode()
        self.assertIn("not the current build of dem-master", page)
        self.assertEqual(b"".join(self.get(f"/runs/{older.pk}/files/log.dem").streaming_content),
                         b"log of serial\nLoop time of 1.5 on 1 procs\n")

    def test_filter_by_state(self):
        html = self.get(self.folder_url("contact_models", show="failed")).content.decode()
        self.assertIn(">hooke/<", html)
        self.assertNotIn(">hertz/<", html)

    def test_test_case_lists_its_runs_with_selection(self):
        html = self.get(self.folder_url("contact_models/hooke/impact")).content.decode()
        self.assertIn("Test case contact_models/hooke/impact", html)
        self.assertIn(f'value="{self.s["failed"].pk}"', html)
        self.assertIn("non-zero exit code", html)
        self.assertIn("not executed", html)
        html = self.get(self.folder_url("contact_models/hooke/impact", show="failed")).content.decode()
        self.assertNotIn(f'value="{self.s["not_run"].pk}"', html)

    def test_consistency_mode_filter(self):
        html = self.get(self.folder_url("contact_models/hertz/impact", mode="consistency",
                                        show="inconsistent")).content.decode()
        self.assertIn(f'value="{self.s["inconsistent"].pk}"', html)
        self.assertNotIn(f'value="{self.s["older"].pk}"', html)

    def test_all_runs_of_a_test_case_across_targets(self):
        html = self.get(self.folder_url("contact_models/hertz/impact")).content.decode()
        self.assertIn('href="/testcases/contact_models/hertz/impact/"', html)
        html = self.get("/testcases/contact_models/hertz/impact/").content.decode()
        for key in ("reference", "inconsistent", "older"):
            self.assertIn(f'value="{self.s[key].pk}"', html)
        self.assertIn("dem-v1@v1", html)

    def test_unknown_folder_is_404(self):
        self.assertEqual(self.client.get(self.folder_url("no/such")).status_code, 404)

    def test_query_count_does_not_grow_with_runs(self):
        url = self.folder_url("bulk")
        leaf = self.folder_url("bulk/group0/case0")
        add_bulk_runs(20, self.s["ws1"], self.s["master"], self.s["new_build"])
        before, before_leaf = self.queries(url), self.queries(leaf)
        add_bulk_runs(300, self.s["ws1"], self.s["master"], self.s["new_build"], prefix="bulk")
        self.assertEqual(self.queries(url), before)
        self.assertEqual(self.queries(leaf), before_leaf)
        self.assertLessEqual(before_leaf, 7)  # the 7th: the failed runs' "failing since", one for the page


class RunDetailTest(DashboardTest):
    def test_everything_of_a_run_is_shown(self):
        run = self.s["inconsistent"]
        html = self.get(f"/runs/{run.pk}/").content.decode()
        self.assertIn("version-consistency-checked", html)
        self.assertIn('{&quot;run&quot;: 2000, &quot;dt&quot;: 2e-5}', html)  # input script, escaped
        self.assertIn("&quot;dt&quot;: &quot;1e-5&quot;", html)               # run configuration
        self.assertIn("Loop time of 1.5", html)                                # log
        self.assertIn(f"stdout of run {run.pk}", html)
        self.assertIn("faster neighbor list", html)                            # build information
        self.assertIn("c" * 40, html)
        for category in ("pair", "neighbor", "communication", "modify", "output", "other"):  # the breakdown's words
            self.assertIn(f"title=\"{category}:", html)
        self.assertIn("pair: 0.4000 s", html)
        self.assertIn("post/dump_100.vtp", html)
        self.assertIn(f'data-plots="/runs/{run.pk}/plots.json"', html)
        specs = json.loads(self.get(f"/runs/{run.pk}/plots.json").content)["plots"]
        # declared torque plot first, then atoms, ke, rke (step is the abscissa), each over the reference run
        # with its C (the same as the stored, independently computed one) and its 5 % and 10 % bands
        self.assertEqual([s["title"] for s in specs], [
            "Torque", "thermo: atoms  (C = 1.0000, perfect)", f"thermo: ke  (C = {self.s['c']:.4f}, inconsistent)",
            "thermo: rke  (C = 1.0000, perfect)"])
        ke = specs[2]
        labels = [s["label"] for s in ke["series"]]
        self.assertIn(f"reference: #{self.s['reference'].pk} dem-v1@v1 (aaaaaaa)", labels)
        self.assertEqual([b["label"] for b in ke["bands"]], ["10 % band (good)", "5 % band (perfect)"])
        self.assertEqual(ke["markers"][0]["x"], self.s["first_bad"])
        self.assertEqual([s["label"] for s in specs[0]["series"]][-1].split(":")[0], "reference")

    def test_axis_columns_are_not_plotted_unless_the_run_configuration_asks(self):
        from harness.store.models import Series

        run = self.s["inconsistent"]
        thermo = Series.objects.get(run=run, kind="thermo")
        thermo.columns = {**thermo.columns, "time": [s * 2e-5 for s in thermo.columns["step"]]}
        thermo.save()
        titles = [s["title"].split("  (")[0] for s in
                  json.loads(self.get(f"/runs/{run.pk}/plots.json").content)["plots"]]
        self.assertNotIn("thermo: time", titles)
        Run.objects.filter(pk=run.pk).update(config={**run.config, "consistency": {"time": {}}})
        titles = [s["title"].split("  (")[0] for s in
                  json.loads(self.get(f"/runs/{run.pk}/plots.json").content)["plots"]]
        self.assertIn("thermo: time", titles)

    def test_log_markup_is_escaped(self):
        html = self.get(f"/runs/{self.s['inconsistent'].pk}/").content.decode()
        self.assertNotIn("<script>alert", html)
        self.assertIn("&lt;script&gt;alert(&#x27;log&#x27;)&lt;/script&gt;", html)
        html = self.get(f"/runs/{self.s['failed'].pk}/").content.decode()
        self.assertIn("Segmentation &lt;fault&gt; &amp; core dumped", html)
        self.assertIn("non-zero exit code: engine exited with code 3", html)

    def test_fixed_query_count(self):
        from harness.store.models import Series

        url = f"/runs/{self.s['inconsistent'].pk}/"
        before = self.queries(url)
        self.assertLessEqual(before, 7)  # the 7th: "failing since" of this inconsistent run
        run = self.s["inconsistent"]
        for i in range(5):
            # of a quantity that is not the bad one: the run stays inconsistent (and "failing since" asked)
            Override.objects.create(run=run, user=self.s["user"], quantity="atoms", reason=f"reason {i}")
            Series.objects.create(run=run, kind="vtk", name=f"dump{i}", x_column="step",
                                  columns={"step": [0, 1], "particles": [4, 4]})
        self.assertEqual(self.queries(url), before)

    def test_plots_are_json_with_units(self):
        response = self.get(f"/runs/{self.s['reference'].pk}/plots.json")
        self.assertEqual(response["Content-Type"], "application/json")
        ke = next(s for s in json.loads(response.content)["plots"] if s["title"] == "thermo: ke")
        self.assertEqual((ke["xlabel"], ke["ylabel"]), ("step [1]", "ke [J]"))
        self.assertEqual(self.client.get("/runs/999999/plots.json").status_code, 404)

    def test_expectations_from_the_run_record(self):
        run = self.s["inconsistent"]
        record = Path(run.folder) / "run.json"
        record.write_text(json.dumps({"verdicts": [
            {"ok": True, "reason": "stability", "message": "stability finite: all values finite"},
            {"ok": False, "reason": "expectation", "message": "expectation thermo.ke (end) = 2 outside 1 +/- 1 %"}]}))
        html = self.get(f"/runs/{run.pk}/").content.decode()
        table = html.split('<table class="expectations">', 1)[1].split("</table>", 1)[0]
        # the failed one first
        self.assertLess(table.index("not met"), table.index("stability finite"))
        self.assertIn("expectation thermo.ke (end) = 2 outside 1 +/- 1 %", table)

    def test_artifact_download_and_traversal(self):
        run = self.s["reference"]
        response = self.get(f"/runs/{run.pk}/files/post/torque.csv")
        self.assertEqual(b"".join(response.streaming_content), b"t,torqueZ\n0,0\n1,0.5\n")
        vtp = b"".join(self.get(f"/runs/{run.pk}/files/post/dump_100.vtp").streaming_content)
        self.assertIn(b"<VTKFile", vtp)
        secret = Path(run.folder).parent / "secret.txt"
        secret.write_text("not yours")
        (Path(run.folder) / "escape").symlink_to(secret)
        for bad in ("../secret.txt", "..%2Fsecret.txt", "post/../../secret.txt", "escape",
                    "%2Fetc%2Fpasswd", "post"):
            self.assertEqual(self.client.get(f"/runs/{run.pk}/files/{bad}").status_code, 404, bad)

    def test_missing_run_is_404(self):
        self.assertEqual(self.client.get("/runs/999999/").status_code, 404)


class CompareTest(DashboardTest):
    def test_two_runs_timing_diffs_and_overlaid_plots(self):
        a, b = self.s["reference"], self.s["inconsistent"]
        html = self.get(f"/compare/?run={a.pk}&run={b.pk}").content.decode()
        self.assertIn("Comparison of 2 runs", html)
        self.assertIn("pair: 0.8000 s", html)
        self.assertIn("pair: 0.4000 s", html)
        self.assertIn('<div class="del">-{&quot;run&quot;: 2000, &quot;dt&quot;: 1e-5}</div>', html)
        self.assertIn('<div class="add">+{&quot;run&quot;: 2000, &quot;dt&quot;: 2e-5}</div>', html)
        self.assertIn("run configuration: identical", html)
        self.assertIn("&lt;script&gt;", html)  # the log diff, escaped
        url = re.search(r'data-plots="(/compare/plots\.json[^"]*)"', html).group(1).replace("&amp;", "&")
        specs = json.loads(self.get(url).content)["plots"]
        titles = [s["title"] for s in specs]
        # per quantity: the overlay, then the second run in the bands around the first and its deviation
        self.assertEqual(titles[0], "Torque")
        ke = titles.index("thermo: ke")
        self.assertEqual(titles[ke + 1], f"thermo: ke  (C = {self.s['c']:.4f}, inconsistent)")
        self.assertTrue(titles[ke + 2].startswith("thermo: ke, deviation from the reference"))
        self.assertEqual(specs[ke + 1]["markers"][0]["x"], self.s["first_bad"])

    def test_the_reference_is_the_reference_targets_run_unless_another_is_chosen(self):
        """Ticked in either order, the reference target's run is the reference: the bands go around it and
        the diff goes from it; ``reference=ID`` chooses another, and the page links to that choice."""
        a, b = self.s["reference"], self.s["inconsistent"]
        html = self.get(f"/compare/?run={b.pk}&run={a.pk}").content.decode()
        self.assertIn(f"Reference: <strong>#{a.pk}", html)
        self.assertIn('<div class="del">-{&quot;run&quot;: 2000, &quot;dt&quot;: 1e-5}</div>', html)
        self.assertLess(html.index('id="compare-plots"'), html.index('<details class="diff">'))  # diffs below
        url = re.search(r'data-plots="(/compare/plots\.json[^"]*)"', html).group(1).replace("&amp;", "&")
        self.assertIn(f"run={a.pk}%2C{b.pk}", url)
        self.assertIn(f'href="?run={a.pk}&amp;run={b.pk}&amp;reference={b.pk}"', html)
        html = self.get(f"/compare/?run={a.pk}&run={b.pk}&reference={b.pk}").content.decode()
        self.assertIn(f"Reference: <strong>#{b.pk}", html)
        self.assertIn('<div class="add">+{&quot;run&quot;: 2000, &quot;dt&quot;: 1e-5}</div>', html)

    def test_three_runs_without_diffs(self):
        ids = [self.s[k].pk for k in ("reference", "inconsistent", "older")]
        html = self.get("/compare/?run=" + ",".join(map(str, ids))).content.decode()
        self.assertIn("Comparison of 3 runs", html)
        self.assertIn("select exactly two", html)
        self.assertEqual(html.count('class="timing-row"'), 3)
        url = re.search(r'data-plots="(/compare/plots\.json[^"]*)"', html).group(1).replace("&amp;", "&")
        titles = [s["title"] for s in json.loads(self.get(url).content)["plots"]]
        self.assertIn(f"thermo: ke, difference to #{ids[0]} dem-v1@v1 (aaaaaaa)", titles)

    def test_timing_bars_share_one_scale(self):
        html = self.get(f"/compare/?run={self.s['older'].pk}&run={self.s['inconsistent'].pk}").content.decode()
        widths = re.findall(r'class="stack" style="width: ([\d.]+)%"', html)
        self.assertEqual(widths, ["100.0", "55.0"])  # 1.1 s of 2.0 s

    def test_a_run_with_a_breakdown_and_no_timing_draws_its_time(self):
        """Runs imported from another machine may carry the breakdown only: the bars read it (not 0 s)."""
        older = self.s["older"]
        Run.objects.filter(pk=older.pk).update(timing={}, breakdown={
            "sections": {"pair": {"avg": 3.0, "min": 2.5, "max": 3.5}, "neighbor": {"avg": 1.0}}, "total": 4.0,
            "ranks": 2, "imbalance": 3.5 / 3.0, "imbalance_of": "pair time"})
        html = self.get(f"/compare/?run={older.pk}&run={self.s['inconsistent'].pk}").content.decode()
        self.assertIn(f'#{older.pk} dem-master@', html)
        self.assertIn('<span class="note">4.000 s</span>', html)
        self.assertEqual(re.findall(r'class="stack" style="width: ([\d.]+)%"', html), ["100.0", "27.5"])
        self.assertIn('title="pair: 3.0000 s"', html)

    def test_nothing_selected(self):
        self.assertIn("Select two or more runs", self.get("/compare/").content.decode())

    def test_fixed_query_count(self):
        two = self.queries(f"/compare/?run={self.s['reference'].pk}&run={self.s['older'].pk}")
        ids = [self.s[k].pk for k in ("reference", "inconsistent", "older", "good")]
        self.assertEqual(self.queries("/compare/?run=" + ",".join(map(str, ids))), two)
        self.assertLessEqual(two, 6)


class ConsistencyTest(DashboardTest):
    def test_opens_as_comparison_with_reference(self):
        run = self.s["inconsistent"]
        html = self.get(f"/runs/{run.pk}/consistency/").content.decode()
        self.assertIn(f"Version consistency of run #{run.pk}", html)
        self.assertIn(f"Reference run: <a href=\"/runs/{self.s['reference'].pk}/\">", html)
        self.assertIn(f"{self.s['c']:.4f}", html)
        self.assertIn("inconsistent", html)
        self.assertIn(f"<td class=\"num\">{self.s['first_bad']}</td>", html)
        self.assertIn("Differences of the files", html)
        self.assertIn(f'data-plots="/runs/{run.pk}/consistency/plots.json"', html)
        specs = json.loads(self.get(f"/runs/{run.pk}/consistency/plots.json").content)["plots"]
        # ke (lowest C first) and atoms: each the bands and the deviation
        self.assertEqual(len(specs), 4)
        self.assertEqual(specs[0]["title"], f"thermo: ke  (C = {self.s['c']:.4f}, inconsistent)")

    def test_lowest_c_listed_first(self):
        html = self.get(f"/runs/{self.s['inconsistent'].pk}/consistency/").content.decode()
        self.assertLess(html.index(">ke<"), html.index(">atoms<"))

    def test_reference_found_without_stored_link(self):
        run = self.s["inconsistent"]
        Run.objects.filter(pk=run.pk).update(reference_run=None)
        html = self.get(f"/runs/{run.pk}/consistency/").content.decode()
        self.assertIn(f"Reference run: <a href=\"/runs/{self.s['reference'].pk}/\">", html)

    def test_without_reference_target(self):
        html = self.get(f"/runs/{self.s['reference'].pk}/consistency/").content.decode()
        self.assertIn("names no reference target", html)


class OverruleTest(DashboardTest):
    def url(self):
        return f"/runs/{self.s['inconsistent'].pk}/override/"

    def test_anonymous_cannot_overrule(self):
        response = self.client.post(self.url(), {"reason": "fine"})
        self.assertEqual(response.status_code, 302)
        self.assertIn("/accounts/login/", response["Location"])
        self.assertFalse(Override.objects.exists())
        html = self.get(f"/runs/{self.s['inconsistent'].pk}/").content.decode()
        self.assertIn("to accept a failure or an inconsistency", html)
        self.assertNotIn('name="reason"', html)

    def test_csrf_token_required(self):
        client = Client(enforce_csrf_checks=True)
        client.force_login(self.s["user"])
        self.assertEqual(client.post(self.url(), {"reason": "fine"}).status_code, 403)
        html = client.get(f"/runs/{self.s['inconsistent'].pk}/").content.decode()
        token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', html).group(1)
        self.assertEqual(client.post(self.url(), {"reason": "fine", "csrfmiddlewaretoken": token})
                         .status_code, 302)
        self.assertEqual(Override.objects.count(), 1)

    def test_reason_required(self):
        self.client.force_login(self.s["user"])
        response = self.client.post(self.url(), {"reason": "   "}, follow=True)
        self.assertFalse(Override.objects.exists())
        self.assertIn("Not overruled: reason: This field is required.", response.content.decode())

    def test_overrule_is_kept_shown_and_counted(self):
        self.client.force_login(self.s["user"])
        response = self.client.post(self.url(), {"reason": "new damping <b>intended</b>", "quantity": "",
                                                 "next": "consistency"}, follow=True)
        self.assertEqual(response.redirect_chain[-1][0], f"/runs/{self.s['inconsistent'].pk}/consistency/")
        override = Override.objects.get()
        self.assertEqual((override.user, override.quantity), (self.s["user"], ""))
        html = response.content.decode()
        self.assertIn("reviewer", html)
        self.assertIn("new damping &lt;b&gt;intended&lt;/b&gt;", html)
        self.assertIn(override.created.strftime("%Y-%m-%d %H:%M"), html)
        html = self.get("/?mode=consistency").content.decode()
        # the overruled run counts as consistent and as passed (the verdict of harness check)
        master = cells(target_rows(html)["dem-master"])
        self.assertEqual(master[6], "2 not checked 2 consistent")  # counts that are not 0, the worst first
        self.assertEqual(master[3:5], ["2", "2"])  # the other failure: the run never executed

    def test_per_quantity_overrule_accepts_when_all_bad_quantities_are_covered(self):
        self.client.force_login(self.s["user"])
        self.client.post(self.url(), {"reason": "ke drift explained", "quantity": "ke"})
        self.assertTrue(Run.objects.with_accepted().get(pk=self.s["inconsistent"].pk).accepted)
        response = self.client.post(self.url(), {"reason": "x", "quantity": "not-a-bad-quantity"}, follow=True)
        self.assertIn("Not overruled: quantity", response.content.decode())

    def test_quantity_keys_match_harness_check(self):
        from harness.analysis.check import verdict_of
        from harness.analysis.consistency import QuantityResult
        from harness.store.models import ConsistencyResult

        run = self.s["inconsistent"]
        ConsistencyResult.objects.create(run=run, reference_run=self.s["reference"], series_kind="plot",
                                         series_name="torqueZ", quantity="torqueZ", value=0.5,
                                         level="inconsistent", epsilon=1e-4, first_bad_step=0.01)
        self.client.force_login(self.s["user"])
        html = self.get(f"/runs/{run.pk}/").content.decode()
        self.assertIn('<option value="torqueZ:torqueZ">', html)
        self.assertIn('<option value="ke">', html)
        self.client.post(self.url(), {"reason": "ke drift explained", "quantity": "ke"})
        self.assertFalse(Run.objects.with_accepted().get(pk=run.pk).accepted)  # torque still open
        self.client.post(self.url(), {"reason": "torque follows ke", "quantity": "torqueZ:torqueZ"})
        self.assertTrue(Run.objects.with_accepted().get(pk=run.pk).accepted)
        # the CLI reads the same overrides the same way
        results = [QuantityResult(r.series_kind, r.series_name, r.quantity, r.value, r.level, r.epsilon,
                                  r.first_bad_step) for r in run.consistency_results.all()]
        self.assertEqual(verdict_of(run, results, True).status, "passed")

    def test_get_is_not_allowed(self):
        self.client.force_login(self.s["user"])
        self.assertEqual(self.client.get(self.url()).status_code, 405)

    def test_login_page(self):
        html = self.get("/accounts/login/?next=/").content.decode()
        self.assertIn("csrfmiddlewaretoken", html)
        response = self.client.post("/accounts/login/", {"username": "reviewer", "password": "pw-for-tests-only",
                                                         "next": "/"})
        self.assertEqual(response.status_code, 302)
        self.assertIn("log out", self.get("/").content.decode())


class HistoryJunitStaticTest(DashboardTest):
    def test_history_lists_builds_oldest_first(self):
        s = self.s
        html = self.get(f"/history/{s['master'].pk}/{s['hertz'].path}/?machine={s['ws1'].pk}").content.decode()
        self.assertIn("History of contact_models/hertz/impact on dem-master", html)
        self.assertLess(html.index("<code>bbbbbbbbbb</code>"), html.index("<code>cccccccccc</code>"))
        self.assertIn("0.9900", html)
        url = re.search(r'data-plots="(/history/[^"]+)"', html).group(1).replace("&amp;", "&")
        # without stepping times only C is plotted; with them, stepping time and start-up (wall - stepping)
        self.assertEqual(len(json.loads(self.get(url).content)["plots"]), 1)
        Run.objects.filter(pk=s["older"].pk).update(stepping_time=0.8)
        Run.objects.filter(pk=s["inconsistent"].pk).update(stepping_time=0.6)
        c_plot, time_plot, startup_plot = json.loads(self.get(url).content)["plots"]
        self.assertEqual(time_plot["series"][0]["values"], [0.8, 0.6])
        self.assertEqual([round(v, 12) for v in startup_plot["series"][0]["values"]], [1.2, 0.5])
        self.assertEqual(c_plot["xticks"], ["bbbbbbb", "ccccccc"])
        self.assertEqual(c_plot["series"][0]["values"], [0.99, self.s["c"]])
        self.assertEqual([x["label"] for x in time_plot["series"]], ["serial stepping time"])
        self.assertEqual([x["label"] for x in startup_plot["series"]], ["serial start-up"])

    def test_regressions_mark_the_commit_that_changed_a_quantity(self):
        s = self.s
        # finished runs: the older build's run is, for its own build, the consistent run it ended as
        Run.objects.exclude(state="not_executed").update(finished=s["older"].started)
        html = self.get("/regressions/").content.decode()
        table = html.split('<table class="regressions">', 1)[1].split("</table>", 1)[0]
        self.assertIn("<code>cccccccccc</code>", table)
        self.assertIn('<span class="change quantity">quantity</span>', table)
        self.assertIn("contact_models/hertz/impact/serial", table)
        self.assertIn(f"ke C = {s['c']:.3g}", table)
        # five histories (hertz on dem-v1 and on master, hooke serial and mpi4, settle): one over two builds
        self.assertIn('in 5 histories, <strong class="comparable">1</strong> of them with runs of two or more builds',
                      html)
        self.assertIn(f'href="/history/{s["master"].pk}/contact_models/hertz/impact/?machine={s["ws1"].pk}"', table)
        url = f"/history/{s['master'].pk}/{s['hertz'].path}/plots.json?machine={s['ws1'].pk}"
        c_plot = json.loads(self.get(url).content)["plots"][0]
        self.assertEqual([m["x"] for m in c_plot["markers"]], [1])
        self.assertIn("quantity", c_plot["markers"][0]["label"])
        self.assertNotIn("<code>cccccccccc</code>",
                         self.get(f"/regressions/?target={s['ref_target'].pk}").content.decode())

    def test_junit_xml(self):
        response = self.get("/junit.xml")
        self.assertEqual(response["Content-Type"], "application/xml")
        root = ET.fromstring(response.content)
        cases = {(c.get("classname"), c.get("name")): c for c in root.iter("testcase")}
        # harness.analysis.check's writer: the target is part of the class name, so two targets' runs never collide
        self.assertEqual(set(cases), {("dem-master.contact_models.hooke.impact", "serial"),
                                      ("dem-master.contact_models.hooke.impact", "mpi4"),
                                      ("dem-master.contact_models.hertz.impact", "serial"),
                                      ("dem-master.packing.settle", "serial"),
                                      ("dem-v1.contact_models.hertz.impact", "serial")})  # not the older build's
        self.assertEqual(cases[("dem-master.contact_models.hooke.impact", "serial")].find("failure").get("type"),
                         "exit_code")
        # a run of the current build that was not executed fails the gate (harness.analysis.coverage), as in the CLI
        self.assertEqual(cases[("dem-master.contact_models.hooke.impact", "mpi4")].find("failure").get("type"),
                         "not_executed")
        inconsistent = cases[("dem-master.contact_models.hertz.impact", "serial")]
        self.assertIn(f"ke: inconsistent, C = {self.s['c']:.4g}", inconsistent.find("failure").get("message"))
        # what the verdict was computed on: commit, test case content, reference and its commit
        self.assertIn("dem-master at cccccccccc, test case 1e1e1e1e1e; reference dem-v1 at aaaaaaaaaa",
                      inconsistent.findtext("system-out"))
        self.assertIsNone(cases[("dem-master.packing.settle", "serial")].find("failure"))
        Override.objects.create(run=self.s["failed"], user=self.s["user"], reason="known crash")
        root = ET.fromstring(self.get(f"/junit.xml?target={self.s['master'].pk}").content)
        cases = {(c.get("classname"), c.get("name")): c for c in root.iter("testcase")}
        overruled = cases[("dem-master.contact_models.hooke.impact", "serial")]
        self.assertIsNone(overruled.find("failure"))
        self.assertIn("reviewer: known crash - overruled the run's failure", overruled.findtext("system-out"))
        self.assertEqual({s.get("name") for s in root.findall("testsuite")},
                         {"dem-master/contact_models/hooke/impact", "dem-master/contact_models/hertz/impact",
                          "dem-master/packing/settle"})

    def test_static_files_served(self):
        response = self.client.get("/static/webfrontend/style.css")
        self.assertEqual(response.status_code, 200)
        self.assertIn(b".bar", b"".join(response.streaming_content))
