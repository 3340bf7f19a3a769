"""Flame graphs in a real browser (headless Debian chromium, Playwright): one run's profile and two runs' as a
differential flame graph, drawn by the vendored d3-flame-graph from the JSON the page fetches; the frame of
the function that grew is red in the differential one."""
from __future__ import annotations

import pytest
from test_browser import ARTIFACTS, CHROMIUM, BrowserCase

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian chromium at /usr/bin/chromium")]


class FlameGraphBrowserTest(BrowserCase):
    def profiled(self, run, stacks: str):
        folder = self.root / f"profile-{run.pk}"
        folder.mkdir()
        (folder / "profile.folded").write_text(stacks)
        run.folder, run.profile = str(folder), "profile.folded"
        run.save(update_fields=["folder", "profile"])
        return run

    def test_flame_graph_and_differential_flame_graph_are_drawn(self):
        a = self.profiled(self.s["reference"], "code;main;pair_forces 50\ncode;main;neighbor_list 50\n")
        b = self.profiled(self.s["inconsistent"], "code;main;pair_forces 150\ncode;main;neighbor_list 50\n")
        self.page.goto(f"{self.live_server_url}/runs/{a.pk}/profile/")
        self.page.wait_for_function("() => document.getElementById('flamegraph').dataset.drawn === '1'")
        names = self.page.locator("#flamegraph svg g title").all_text_contents()
        assert any(n.startswith("pair_forces") for n in names) and any(n.startswith("main") for n in names)
        self.page.goto(f"{self.live_server_url}/profiles/diff/?run={a.pk},{b.pk}")
        self.page.wait_for_function("() => document.getElementById('flamegraph').dataset.drawn === '1'")
        fill = self.page.eval_on_selector(
            "#flamegraph svg", "svg => [...svg.querySelectorAll('g')].find(g => (g.querySelector('title') || {})"
            ".textContent?.startsWith('pair_forces')).querySelector('rect').getAttribute('fill')")
        red, green, blue = [int(v) for v in fill[fill.index("(") + 1:-1].split(",")]
        assert red > green and red > blue, fill  # grew: red (d3-flame-graph's differential colours)
        self.page.wait_for_timeout(1000)  # d3-flame-graph's transitions
        self.page.screenshot(path=str(ARTIFACTS / "flamegraph_differential.png"), full_page=True)

    def test_scaling_page_draws_speedup_and_efficiency_over_commits(self):
        from harness.analysis import scaling
        from harness.store.models import Build, Run

        build = self.s["new_build"]
        Build.objects.filter(pk=build.pk).update(current=True)
        case = self.s["inconsistent"].testcase
        for point, seconds in zip(scaling.expand({"name": "box", "script": "s.json", "scaling": {"cores": [1, 2]}},
                                                 "threads"), (4.0, 2.5)):
            Run.objects.create(machine=build.machine, target=build.target, build=build, testcase=case,
                               name=point["name"], state="post_processed", config=point, stepping_time=seconds)
        self.page.goto(f"{self.live_server_url}/scaling/")
        assert self.charts_drawn(".scaling .plots") == 2
        self.page.screenshot(path=str(ARTIFACTS / "scaling.png"), full_page=True)
