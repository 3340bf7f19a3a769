"""Every dashboard page, with all its plots drawn, in a real browser over a store of 10,000 runs.

The time of a page is from the start of navigation until every plot box has drawn (``data-drawn`` set by
plots.js) - what a reviewer waits for. Each page is loaded three times; the median is written to
test-artifacts/page_times.json with the number of runs. The goal is under 1 s a page; the test fails above
``LIMIT`` s, a margin for a busy CI machine (the figures themselves are in the artifact). On a 2-core machine
under a load of about 5 the slowest pages (compare builds, the commit page, regressions, a search listing runs)
took 0.5-0.75 s; ``python benchmarks/dashboard_pages.py`` gives their server time alone. On a machine about half
as fast (2 vCPUs under KVM) the same pages took 0.58-1.26 s when the test ran alone and the commit page
1.9 s inside the full suite: a margin of 1.5 s failed a page that was not slower, so the margin is 3 s. A page
that made a query per run would make 10,000 of them here.
"""
from __future__ import annotations

import json
import statistics
import time

import pytest
from test_browser import ARTIFACTS, BrowserCase

RUNS = 10_000
GOAL = 1.0
LIMIT = 3.0


@pytest.mark.slow
class BrowserScaleTest(BrowserCase):
    def test_every_page_with_its_plots_under_a_second_with_ten_thousand_runs(self):
        from dashboard_data import add_bulk_runs

        from harness.store.models import Run

        s = self.s
        add_bulk_runs(RUNS - Run.objects.count(), s["ws1"], s["master"], s["new_build"])
        assert Run.objects.count() >= RUNS
        run, other = s["inconsistent"].pk, s["reference"].pk
        target = s["master"].pk
        pages = {
            "overview": "/",
            "overview, consistency mode": "/?mode=consistency",
            "folder": f"/m/{s['ws1'].pk}/t/{target}/",
            "folder of 10,000 runs": f"/m/{s['ws1'].pk}/t/{target}/f/bulk/",
            "test case run list": f"/testcases/{s['inconsistent'].testcase.path}/",
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
        times = {}
        for name, url in pages.items():
            samples = []
            for _ in range(3):
                started = time.perf_counter()
                response = self.page.goto(self.live_server_url + url)
                assert response.status == 200, f"{name}: HTTP {response.status}"
                self.page.wait_for_function("() => [...document.querySelectorAll('[data-plots]')]"
                                            ".every(b => b.dataset.drawn !== undefined && b.dataset.drawn !== 'error')")
                samples.append(time.perf_counter() - started)
            times[name] = statistics.median(samples)
        ARTIFACTS.mkdir(exist_ok=True)
        (ARTIFACTS / "page_times.json").write_text(json.dumps(
            {"runs": Run.objects.count(), "goal_s": GOAL, "median_s": times}, indent=1))
        slow = {name: round(t, 3) for name, t in times.items() if t > LIMIT}
        assert not slow, f"pages slower than {LIMIT} s with {RUNS} runs: {slow}"
