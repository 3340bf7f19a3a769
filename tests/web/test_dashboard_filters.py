"""Search and filters of the run lists (overview, folders, a test case's runs): by test case or run name, by
revision (commit prefix or build), by state and by failure reason; kept in every link so a filtered view can
be shared."""
from __future__ import annotations

import html as htmllib
import re

from test_dashboard_views import DashboardTest


def run_ids(html: str) -> set[int]:
    return {int(i) for i in re.findall(r'name="run" value="(\d+)"', html)}


class SearchTest(DashboardTest):
    def test_overview_counts_only_matching_runs(self):
        from test_dashboard_views import cells, target_rows

        html = self.get("/?q=HOOKE").content.decode()  # any case
        # dem-master's hooke runs: one failed, one never executed (a failure of the gate), none passed; and
        # they are listed
        assert cells(target_rows(html)["dem-master"])[3:6] == ["0", "2", "0"]
        assert run_ids(html) == {self.s["failed"].pk, self.s["not_run"].pk}
        # the reference target ran no hooke case: not shown at all
        assert ">dem-v1</a>" not in html
        assert "whose test case or name holds <q>HOOKE</q>" in html
        # the filter stays in the links: mode switch, target and folder links
        assert 'href="?mode=consistency&amp;q=HOOKE"' in html
        assert f'/m/{self.s["ws1"].pk}/t/{self.s["master"].pk}/?mode=state&amp;q=HOOKE"' in html

    def test_search_by_run_name_in_a_test_case_folder(self):
        html = self.get(self.folder_url("contact_models/hooke/impact", q="mpi")).content.decode()
        assert run_ids(html) == {self.s["not_run"].pk}
        html = self.get(self.folder_url("contact_models", q="nothing-like-this")).content.decode()
        assert "No run of the current build here matches the filters." in html

    def test_filter_by_state_and_failure_reason(self):
        s = self.s
        html = self.get(self.folder_url("contact_models/hooke/impact", state="failed")).content.decode()
        assert run_ids(html) == {s["failed"].pk}
        html = self.get(self.folder_url("contact_models/hooke/impact", reason="exit_code")).content.decode()
        assert run_ids(html) == {s["failed"].pk}
        html = self.get(self.folder_url("contact_models/hooke/impact", reason="timeout")).content.decode()
        assert run_ids(html) == set() and "No run of the current build matches the filters" in html
        html = self.get("/?state=consistency_checked").content.decode()
        from test_dashboard_views import target_rows

        assert run_ids(html) == {s["inconsistent"].pk, s["good"].pk} and list(target_rows(html)) == ["dem-master"]

    def test_filter_by_commit_prefix_and_build_on_a_test_case_list(self):
        s = self.s
        hertz = "/testcases/contact_models/hertz/impact/"
        assert run_ids(self.get(hertz).content.decode()) == {s["reference"].pk, s["inconsistent"].pk,
                                                             s["older"].pk}
        assert run_ids(self.get(hertz + "?commit=BBB").content.decode()) == {s["older"].pk}
        assert run_ids(self.get(hertz + "?commit=" + "c" * 40).content.decode()) == {s["inconsistent"].pk}
        assert run_ids(self.get(hertz + f"?build={s['new_build'].pk}").content.decode()) == {s["inconsistent"].pk}
        assert run_ids(self.get(hertz + "?commit=ccc&state=outdated").content.decode()) == set()

    def test_filters_combine_and_are_kept_in_page_and_mode_links(self):
        s = self.s
        html = self.get(self.folder_url("", q="impact", state="failed", mode="consistency")).content.decode()
        assert "contact_models/" in html and "packing" not in html
        assert "q=impact&amp;state=failed" in html
        form = html[html.index('class="filters search"'):html.index("</form>", html.index('class="filters search"'))]
        assert 'name="q" value="impact"' in form and '<option value="failed" selected>' in form
        assert '<input type="hidden" name="mode" value="consistency">' in form

    def test_values_are_escaped_and_percent_signs_are_literal(self):
        html = self.get('/?q=%22%3E%3Cscript%3Ex%3C%2Fscript%3E').content.decode()
        assert "<script>x</script>" not in html and "&lt;script&gt;" in html
        assert "dem-master" not in self.get("/?q=%25").content.decode()  # '%' is a character, not a wildcard

    def test_bad_filter_values_are_400_naming_them(self):
        for url, message in [("/?commit=xyz", "commit: 'xyz' is not the start of a commit id"),
                             ("/?state=broken", "state: 'broken' is not one of not_executed, executed"),
                             ("/?reason=none", "reason: 'none' is not one of exit_code, signal"),
                             ("/?build=1.5", "build: '1.5' is not an id"),
                             ("/?q=a&q=b", "q: given 2 times; give it once")]:
            response = self.client.get(url)
            assert response.status_code == 400, url
            assert message in htmllib.unescape(response.content.decode()), url

    def test_filters_cost_no_extra_queries(self):
        plain = self.queries(self.folder_url("contact_models/hooke/impact"))
        filtered = self.queries(self.folder_url("contact_models/hooke/impact", q="serial", commit="cc",
                                                state="failed", reason="exit_code"))
        assert filtered == plain
