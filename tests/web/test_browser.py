"""The dashboard in a real browser: headless Debian chromium driven by Playwright against a live server.

Overview -> folders -> a run -> back -> select two runs -> compare; screenshots go to test-artifacts/.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest
from dashboard_data import make_store
from django.contrib.staticfiles.testing import StaticLiveServerTestCase

from harness.execution.workspace import PROJECT_ROOT

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = PROJECT_ROOT / "test-artifacts"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not CHROMIUM.exists(),
                                 reason="needs Debian chromium at /usr/bin/chromium (apt-get install chromium)")]


class BrowserCase(StaticLiveServerTestCase):
    """A live server over a filled store and a chromium page; the tests are in the subclasses."""

    host = "127.0.0.1"

    @classmethod
    def setUpClass(cls):
        # Playwright's sync API keeps an event loop in this thread; Django's ORM calls here stay
        # synchronous, which Django's documentation allows with this switch for exactly this case.
        cls._async_unsafe = os.environ.get("DJANGO_ALLOW_ASYNC_UNSAFE")
        os.environ["DJANGO_ALLOW_ASYNC_UNSAFE"] = "true"
        super().setUpClass()
        from playwright.sync_api import sync_playwright

        cls.playwright = sync_playwright().start()
        cls.browser = cls.playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)

    @classmethod
    def tearDownClass(cls):
        cls.browser.close()
        cls.playwright.stop()
        super().tearDownClass()
        if cls._async_unsafe is None:
            os.environ.pop("DJANGO_ALLOW_ASYNC_UNSAFE", None)

    def setUp(self):
        self.root = Path(tempfile.mkdtemp(prefix="dashboard-browser-"))
        self.s = make_store(self.root)
        self.page = self.browser.new_page(viewport={"width": 1280, "height": 900})
        ARTIFACTS.mkdir(exist_ok=True)

    def tearDown(self):
        self.page.close()
        shutil.rmtree(self.root, ignore_errors=True)

    def charts_drawn(self, selector: str) -> int:
        """Number of plots uPlot drew into the box ``selector`` once its JSON arrived (0: none, or an error)."""
        self.page.wait_for_function(f"() => document.querySelector({selector!r}).dataset.drawn !== undefined")
        drawn = self.page.eval_on_selector(selector, "b => b.dataset.drawn")
        assert drawn != "error", self.page.eval_on_selector(selector, "b => b.innerText")
        assert self.page.locator(f"{selector} .chart canvas").count() == int(drawn)
        return int(drawn)

    def screenshot(self, name: str) -> None:
        """Full-page screenshot after every plot box has drawn its plots."""
        self.page.wait_for_function("() => [...document.querySelectorAll('[data-plots]')]"
                                    ".every(b => b.dataset.drawn !== undefined)")
        self.page.screenshot(path=str(ARTIFACTS / name), full_page=True)


class BrowserTest(BrowserCase):
    def test_browse_to_a_run_then_compare_two_runs(self):
        page, s = self.page, self.s
        page.goto(self.live_server_url + "/")
        assert page.locator("h2", has_text="machine ws1").is_visible()
        self.screenshot("dashboard_overview.png")
        master = page.locator("tr.target", has=page.locator("a", has_text="dem-master"))
        assert master.locator("td").nth(0).inner_text() == "FAILED"  # upper case by the style sheet
        assert master.locator("td").nth(4).inner_text() == "3"  # failed, inconsistent, never executed

        # browse like a file browser: dem-master -> contact_models/ -> hertz/ -> impact
        master.get_by_role("link", name="dem-master").click()
        page.get_by_role("link", name="contact_models/").click()
        page.get_by_role("link", name="hertz/").click()
        page.get_by_role("link", name="impact").click()
        assert page.locator("h1").inner_text() == "Test case contact_models/hertz/impact"

        # a run: state, timing, input script, plots drawn by the server
        page.get_by_role("link", name=f"#{s['inconsistent'].pk} serial").click()
        assert page.locator("h1").inner_text() == f"Run #{s['inconsistent'].pk} contact_models/hertz/impact/serial"
        assert page.get_by_text("version-consistency-checked").first.is_visible()
        assert page.locator(".stack .seg").count() == 6
        assert '"dt": 2e-5' in page.locator("details.text[open] pre").first.inner_text()
        assert self.charts_drawn("#run-plots") == 4  # torque, atoms, ke, rke
        self.screenshot("dashboard_run.png")

        # back to the test case (it lists the current build's runs), on to its history over the builds of
        # dem-master, select the two master runs there, compare them
        page.go_back()
        assert page.get_by_label(f"select run {s['older'].pk}").count() == 0
        page.get_by_role("link", name="history over the builds of dem-master").click()
        page.get_by_label(f"select run {s['older'].pk}").check()
        page.get_by_label(f"select run {s['inconsistent'].pk}").check()
        page.get_by_role("button", name="compare selected runs").click()
        assert page.locator("h1").inner_text() == "Comparison of 2 runs"
        assert page.locator(".timing-row").count() == 2
        # the file diffs come after the plots, closed: a click opens one
        assert page.evaluate("() => [...document.querySelectorAll('h2')].map(h => h.innerText.split(':')[0])"
                             ".indexOf('Plots') < [...document.querySelectorAll('h2')]"
                             ".findIndex(h => h.innerText.startsWith('Differences'))")
        diff = page.locator("details.diff", has_text="input script")
        assert diff.get_attribute("open") is None
        diff.locator("summary").click()
        # the history lists the older build first, so the diff goes from the older run to the newer one
        assert '-{"run": 2000, "dt": 1e-5}\n+{"run": 2000, "dt": 2e-5}' in diff.inner_text()
        assert page.get_by_text("run configuration: identical").is_visible()
        assert self.charts_drawn("#compare-plots") > 4
        self.screenshot("dashboard_compare.png")

    def test_consistency_view_with_bands(self):
        page, s = self.page, self.s
        page.goto(self.live_server_url + "/?mode=consistency")
        master = page.locator("tr.target", has=page.locator("a", has_text="dem-master"))
        assert "1 inconsistent" in master.locator("td").nth(6).inner_text()
        page.goto(self.live_server_url + f"/runs/{s['inconsistent'].pk}/consistency/")
        assert page.locator("table.results tr", has_text="ke").first.locator("td").nth(5).inner_text() == "1000"
        assert self.charts_drawn("#consistency-plots") == 4
        self.screenshot("dashboard_consistency.png")

        # the history of the test case over the builds of dem-master, oldest first
        page.goto(self.live_server_url + f"/runs/{s['inconsistent'].pk}/")
        page.get_by_role("link", name="runs of this test case over the builds of dem-master").click()
        assert page.locator("h1").inner_text() == "History of contact_models/hertz/impact on dem-master"
        builds = page.locator("table.runs tbody tr td:nth-child(4)").all_inner_texts()
        assert builds == ["dem-master@HEAD~1", "dem-master@HEAD current"]
        computed_on = page.locator("table.runs tbody tr td:nth-child(8)").all_inner_texts()
        assert computed_on == ["commit bbbbbbbbbb, test case 1e1e1e1e1e, reference dem-v1 aaaaaaaaaa",
                               "commit cccccccccc, test case 1e1e1e1e1e, reference dem-v1 aaaaaaaaaa"]
        assert self.charts_drawn("#history-plots") == 1  # C; this store holds no stepping times to plot
        self.screenshot("dashboard_history.png")

    def test_plots_zoom_hover_and_switch_series(self):
        page, s = self.page, self.s
        page.goto(self.live_server_url + f"/runs/{s['inconsistent'].pk}/consistency/")
        self.charts_drawn("#consistency-plots")
        chart = page.locator("#consistency-plots .chart").first
        over = chart.locator(".u-over")
        box = over.bounding_box()

        # hover: the legend shows the values under the cursor (the reference's ke at the first step is 1e-3)
        page.mouse.move(box["x"] + 1, box["y"] + box["height"] / 2)
        legend = chart.locator(".u-legend")
        page.wait_for_function("el => el.innerText.includes('0.001')", arg=legend.element_handle())
        reference_row = legend.locator(".u-series", has_text="reference:")
        assert reference_row.locator(".u-value").inner_text() == "0.001"

        # zoom: dragging over the middle third narrows the x scale; a double-click gives the whole range back
        def x_range():
            return page.evaluate("() => { const u = document.querySelector('#consistency-plots .chart').uplot;"
                                 " return [u.scales.x.min, u.scales.x.max]; }")
        whole = x_range()
        page.mouse.move(box["x"] + box["width"] / 3, box["y"] + 10)
        page.mouse.down()
        page.mouse.move(box["x"] + 2 * box["width"] / 3, box["y"] + box["height"] - 10, steps=5)
        page.mouse.up()
        zoomed = x_range()
        assert whole[0] < zoomed[0] < zoomed[1] < whole[1], (whole, zoomed)
        over.dblclick()
        assert x_range() == whole

        # series off and on: a click on a legend entry hides its curve
        run_row = legend.locator(".u-series", has_text=f"#{s['inconsistent'].pk} dem-master")
        index = page.evaluate("() => document.querySelector('#consistency-plots .chart').uplot.series.length - 1")
        shown = f"() => document.querySelector('#consistency-plots .chart').uplot.series[{index}].show"
        assert page.evaluate(shown) is True
        run_row.click()
        assert page.evaluate(shown) is False and "u-off" in run_row.get_attribute("class")
        run_row.click()
        assert page.evaluate(shown) is True
        # bands and the first step out of band are drawn: two band entries, one marker named under the plot
        assert legend.locator(".u-series:visible", has_text="10 % band (good)").count() == 1
        assert "first out of band: 1000" in chart.locator("figcaption.markers").inner_text()
        self.screenshot("dashboard_consistency_zoomed.png")

    def test_run_page_fits_a_phone(self):
        page, s = self.page, self.s
        page.set_viewport_size({"width": 390, "height": 844})
        for url in (f"/runs/{s['inconsistent'].pk}/", "/", f"/runs/{s['inconsistent'].pk}/consistency/",
                    f"/builds/compare/?a={s['older'].build_id}&b={s['new_build'].pk}"):
            page.goto(self.live_server_url + url)
            if page.locator("[data-plots]").count():
                self.screenshot(f"dashboard_phone_{url.strip('/').split('/')[0] or 'overview'}.png")
            width = page.evaluate("() => document.documentElement.scrollWidth")
            assert width <= 390, f"{url}: the page is {width} px wide on a 390 px screen"
        page.goto(self.live_server_url + f"/runs/{s['inconsistent'].pk}/")
        self.charts_drawn("#run-plots")
        widths = page.eval_on_selector_all("#run-plots canvas", "cs => cs.map(c => c.getBoundingClientRect().width)")
        assert widths and max(widths) <= 390
        self.screenshot("dashboard_phone_run.png")

    def test_sweep_plots_in_parallel(self):
        """The sweeps page's plots are requested at once by the browser; none fails (pyplot's global state
        gave 500s here), and 16 requests in parallel from threads all succeed."""
        import urllib.request
        from concurrent.futures import ThreadPoolExecutor

        from harness.config.sweep import expand
        from harness.store.models import Run, Series

        s = self.s
        spec = {"variable": "DT", "values": [4e-4, 2e-4, 1e-4], "error": {"quantity": "thermo.z", "exact": 1.0}}
        for name in ("dt", "dt2", "dt3", "dt4"):
            for point in expand({"name": name, "script": "scene.json", "sweep": spec}):
                dt = point["variables"]["DT"]
                run = Run.objects.create(machine=s["ws1"], target=s["master"], build=s["new_build"],
                                         testcase=s["settle"], name=point["name"], state="post_processed",
                                         config=point, wall_time=1e-3 / dt)
                Series.objects.create(run=run, kind="thermo", name="thermo", x_column="step",
                                      columns={"step": [0, 100], "z": [0.0, 1.0 + 5e4 * dt ** 2]})
        self.page.goto(self.live_server_url + "/sweeps/")
        boxes = self.page.locator("[data-plots]")
        assert boxes.count() == 4
        self.screenshot("dashboard_sweeps.png")
        assert self.page.locator("[data-plots] .chart canvas").count() == 8
        assert self.page.locator("[data-plots] .failure").count() == 0
        url = self.live_server_url + boxes.first.get_attribute("data-plots")
        with ThreadPoolExecutor(8) as pool:
            statuses = list(pool.map(lambda _: urllib.request.urlopen(url).status, range(16)))
        assert statuses == [200] * 16
