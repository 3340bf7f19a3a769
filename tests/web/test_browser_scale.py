"""Every dashboard page, with all its plots drawn, in a real browser over a store of 3,000 and then 10,000 runs.

What a page may not do with more runs is draw more: each page is loaded once with 3,000 runs and once with
10,000, and the second may not hold more elements than the first, beyond a margin for a few more distinct values
(``MARGIN``). A page that listed or plotted every run would hold thousands more. The bulk runs are spread over 10
test cases, so that with 3,000 each case's run list already fills a page (``DASHBOARD_LIST_PAGE_SIZE``, 200).
Every plot box must have drawn (``data-drawn`` set by plots.js, not ``error``) both times.

Time is not asserted here: a test cannot tell a slow page from a busy machine. The load times of the 10,000-run
pages, from the start of navigation until every plot has drawn, are written to test-artifacts/page_times.json
as figures; ``python benchmarks/dashboard_pages.py`` times the server's side of each page over 10,000 runs, and
tests/web/test_dashboard_efficiency.py checks that the queries a page makes do not grow with runs.
"""
from __future__ import annotations

import json
import time

import pytest
from test_browser import ARTIFACTS, BrowserCase

FEW, RUNS = 3_000, 10_000
#: elements a page may gain between FEW and RUNS runs: factor and count
MARGIN = (1.1, 50)
PLOTS_DRAWN = ("() => [...document.querySelectorAll('[data-plots]')]"
               ".every(b => b.dataset.drawn !== undefined && b.dataset.drawn !== 'error')")


@pytest.mark.slow
class BrowserScaleTest(BrowserCase):
    def pages(self) -> dict[str, str]:
        s = self.s
        run, other = s["inconsistent"].pk, s["reference"].pk
        target = s["master"].pk
        return {
            "overview": "/",
            "overview, consistency mode": "/?mode=consistency",
            "folder": f"/m/{s['ws1'].pk}/t/{target}/",
            "folder of the bulk runs": f"/m/{s['ws1'].pk}/t/{target}/f/bulk/",
            "test case run list": f"/testcases/{s['inconsistent'].testcase.path}/",
            "run list of a bulk test case": "/testcases/bulk/group0/case0/",
            "run with plots": f"/runs/{run}/",
            "consistency with plots": f"/runs/{run}/consistency/",
            "compare two runs": f"/compare/?run={other}&run={run}",
            "compare builds": f"/builds/compare/?a={s['older'].build_id}&b={s['new_build'].pk}",
            "commit page": f"/commits/dem-master/{s['new_build'].commit}/?machine=ws1",
            "search listing runs": "/?q=bulk",
            "history with plots": f"/history/{target}/{s['inconsistent'].testcase.path}/",
            "regressions": f"/regressions/?machine={s['ws1'].pk}",
            "sweeps": "/sweeps/",
            "matrix": "/matrix/",
        }

    def load(self, name: str, url: str) -> tuple[int, float]:
        """(elements in the drawn page, seconds from navigation until every plot has drawn)."""
        started = time.perf_counter()
        response = self.page.goto(self.live_server_url + url)
        assert response.status == 200, f"{name}: HTTP {response.status}"
        self.page.wait_for_function(PLOTS_DRAWN)
        seconds = time.perf_counter() - started
        return self.page.evaluate("() => document.getElementsByTagName('*').length"), seconds

    def test_no_page_draws_more_with_ten_times_the_runs(self):
        from dashboard_data import add_bulk_runs

        from harness.store.models import Run

        s = self.s
        add_bulk_runs(FEW - Run.objects.count(), s["ws1"], s["master"], s["new_build"])
        few = {name: self.load(name, url)[0] for name, url in self.pages().items()}
        add_bulk_runs(RUNS - Run.objects.count(), s["ws1"], s["master"], s["new_build"])
        assert Run.objects.count() == RUNS
        many, times = {}, {}
        for name, url in self.pages().items():
            many[name], times[name] = self.load(name, url)
        ARTIFACTS.mkdir(exist_ok=True)
        (ARTIFACTS / "page_times.json").write_text(json.dumps(
            {"runs": RUNS, "seconds": times, "elements": {"runs": [FEW, RUNS], **{
                name: [few[name], many[name]] for name in few}}}, indent=1))
        factor, count = MARGIN
        grown = {name: (few[name], many[name]) for name in few if many[name] > few[name] * factor + count}
        assert not grown, f"pages with more elements at {RUNS} runs than at {FEW} (before, after): {grown}"
