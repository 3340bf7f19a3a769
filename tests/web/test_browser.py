"""The dashboard in a real browser: headless Debian chromium driven by Playwright against a live server.

Overview -> folders -> a run -> back -> select two runs -> compare; screenshots go to test-artifacts/.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest
from django.contrib.staticfiles.testing import StaticLiveServerTestCase

from dashboard_data import make_store
from harness.workspace import PROJECT_ROOT

CHROMIUM = Path("/usr/bin/chromium")
ARTIFACTS = PROJECT_ROOT / "test-artifacts"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not CHROMIUM.exists(),
                                 reason="needs Debian chromium at /usr/bin/chromium (apt-get install chromium)")]


class BrowserTest(StaticLiveServerTestCase):
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

    def image_loaded(self, selector: str) -> bool:
        """Whether the first image matching ``selector`` (lazily loaded) arrives and decodes as a picture."""
        self.page.locator(selector).first.scroll_into_view_if_needed()
        self.page.wait_for_function(f"() => document.querySelector({selector!r}).complete")
        return self.page.eval_on_selector(selector, "img => img.naturalWidth > 0")

    def screenshot(self, name: str) -> None:
        """Full-page screenshot after every lazily loaded plot has arrived."""
        for img in self.page.locator("img").all():
            img.scroll_into_view_if_needed()
        self.page.wait_for_function("() => [...document.images].every(i => i.complete)")
        self.page.screenshot(path=str(ARTIFACTS / name), full_page=True)

    def test_browse_to_a_run_then_compare_two_runs(self):
        page, s = self.page, self.s
        page.goto(self.live_server_url + "/")
        assert page.locator("h2", has_text="machine ws1").is_visible()
        self.screenshot("dashboard_overview.png")
        master = page.locator("div.target", has=page.locator("h3 a", has_text="dem-master"))
        assert "1 failed" in master.locator("tr", has_text="contact_models/").inner_text()

        # browse like a file browser: contact_models/ -> hertz/ -> impact
        master.get_by_role("link", name="contact_models/").click()
        page.get_by_role("link", name="hertz/").click()
        page.get_by_role("link", name="impact").click()
        assert page.locator("h1").inner_text() == "Test case contact_models/hertz/impact"

        # a run: state, timing, input script, plots drawn by the server
        page.get_by_role("link", name=f"#{s['inconsistent'].pk} serial").click()
        assert page.locator("h1").inner_text() == f"Run #{s['inconsistent'].pk} contact_models/hertz/impact/serial"
        assert page.get_by_text("version-consistency-checked").first.is_visible()
        assert page.locator(".stack .seg").count() == 6
        assert '"dt": 2e-5' in page.locator("details.text[open] pre").first.inner_text()
        assert self.image_loaded(".plots img")
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
        diff = page.locator("details.diff", has_text="input script")
        # the history lists the older build first, so the diff goes from the older run to the newer one
        assert '-{"run": 2000, "dt": 1e-5}\n+{"run": 2000, "dt": 2e-5}' in diff.inner_text()
        assert page.get_by_text("run configuration: identical").is_visible()
        assert self.image_loaded(".plots img")
        self.screenshot("dashboard_compare.png")

    def test_consistency_view_with_bands(self):
        page, s = self.page, self.s
        page.goto(self.live_server_url + "/?mode=consistency")
        master = page.locator("div.target", has=page.locator("h3 a", has_text="dem-master"))
        assert "1 inconsistent" in master.locator("tr", has_text="contact_models/").inner_text()
        page.goto(self.live_server_url + f"/runs/{s['inconsistent'].pk}/consistency/")
        assert page.locator("table.results tr", has_text="ke").first.locator("td").nth(5).inner_text() == "1000"
        assert self.image_loaded(".plots img")
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
        assert self.image_loaded("figure img")
        self.screenshot("dashboard_history.png")
