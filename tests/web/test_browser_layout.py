"""Every dashboard page at a desktop width (1400 px) and a phone width (390 px) in a real browser.

Two rules a reader notices at once when broken, checked on every page at both widths:
- a table cell holding one word or number (no space in it) is never broken over two lines ("sele ct",
  "0.94 91");
- the page itself never scrolls sideways; a table wider than the screen scrolls inside its own box.
Full-page screenshots go to test-artifacts/layout_<page>_<width>.png, to be looked at.

And on the pages with plots (run, consistency, compare, history, scaling), at both widths: no axis title
overlaps its tick labels (uPlot draws both on a canvas, so the check measures the tick labels with the
canvas' own font and compares them with the room uPlot left between the ticks and the title).
"""
from __future__ import annotations

import pytest
from test_browser import ARTIFACTS, BrowserCase

WIDTHS = (1400, 390)

#: for every cell of every table whose text has no white space: the number of distinct line tops of each of
#: its text nodes (more than one: the word was broken); returns the offenders as "text (lines)"
BROKEN_WORDS = """() => {
  const broken = [];
  for (const cell of document.querySelectorAll('main td, main th')) {
    const text = cell.innerText.trim();
    if (!text || /\\s/.test(text)) continue;
    const walker = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    for (let node = walker.nextNode(); node; node = walker.nextNode()) {
      if (!node.textContent.trim()) continue;
      const range = document.createRange();
      range.selectNodeContents(node);
      const tops = new Set([...range.getClientRects()].filter(r => r.width > 0 && r.height > 0)
                           .map(r => Math.round(r.top)));
      if (tops.size > 1) { broken.push(`${text} (${tops.size} lines)`); break; }
    }
  }
  return broken;
}"""

#: elements wider than the screen that are not inside a box that scrolls sideways on its own
OVERFLOWING = """(width) => {
  const out = [];
  for (const el of document.querySelectorAll('body *')) {
    const r = el.getBoundingClientRect();
    if (r.right <= width + 1 || r.width === 0) continue;
    let p = el.parentElement, boxed = false;
    while (p && p !== document.body) {
      const style = getComputedStyle(p);
      if (['auto', 'scroll', 'hidden'].includes(style.overflowX) && p.getBoundingClientRect().right <= width + 1) {
        boxed = true; break;
      }
      p = p.parentElement;
    }
    if (!boxed) out.push(el.tagName.toLowerCase() + (el.className ? '.' + el.className : '') + ` (${Math.round(r.right)} px)`);
  }
  return out.slice(0, 10);
}"""


#: per drawn plot and axis with a title: the tick labels that need more room than the axis leaves them (its
#: size less tick length and gap: beyond that the axis title is drawn); offenders as "plot title: axis: need > room"
AXIS_OVERLAPS = """() => {
  const out = [];
  for (const figure of document.querySelectorAll('figure.chart')) {
    const u = figure.uplot;
    if (!u) continue;
    u.axes.forEach((axis, i) => {
      if (!axis.show || !axis.label || !axis._values || !axis._size) return;
      const ctx = u.ctx;
      ctx.save();
      ctx.font = axis.font[0];              // uPlot's font at the device pixel ratio
      const labels = axis._values.filter(v => v !== null && v !== undefined && String(v) !== '');
      const widths = labels.map(v => ctx.measureText(String(v)).width / devicePixelRatio);
      ctx.restore();
      if (!widths.length) return;
      const height = axis.font[2] || axis.font[1] / devicePixelRatio;   // css px
      const angle = Math.abs((axis.rotate || 0) * Math.PI / 180);
      const vertical = axis.side % 2 === 1;                             // left (3) or right (1)
      const need = vertical ? Math.max(...widths)
                            : Math.max(...widths.map(w => w * Math.sin(angle) + height * Math.cos(angle)));
      const room = axis._size - (axis.ticks.show ? axis.ticks.size : 0) - axis.gap;
      if (need > room + 0.5) out.push(`${u.root.querySelector('.u-title')?.innerText}: axis ${i} ` +
                                      `(${axis.label}): tick labels need ${need.toFixed(1)} px, room ${room.toFixed(1)} px`);
    });
  }
  return out;
}"""


class LayoutTest(BrowserCase):
    def pages(self) -> dict[str, str]:
        s = self.s
        run, other, target = s["inconsistent"].pk, s["reference"].pk, s["master"].pk
        case = s["inconsistent"].testcase.path
        return {
            "overview": "/",
            "overview_consistency": "/?mode=consistency",
            "folder": f"/m/{s['ws1'].pk}/t/{target}/",
            "folder_testcase": f"/m/{s['ws1'].pk}/t/{target}/f/{case}/",
            "testcase": f"/testcases/{case}/",
            "search": "/?q=impact",
            "run": f"/runs/{run}/",
            "run_failed": f"/runs/{s['failed'].pk}/",
            "consistency": f"/runs/{run}/consistency/",
            "compare": f"/compare/?run={other}&run={run}",
            "compare_builds": f"/builds/compare/?a={s['older'].build_id}&b={s['new_build'].pk}",
            "compare_builds_default": "/builds/compare/",
            "history": f"/history/{target}/{case}/",
            "commit": f"/commits/dem-master/{s['new_build'].commit}/?machine=ws1",
            "regressions": f"/regressions/?machine={s['ws1'].pk}",
            "sweeps": "/sweeps/",
            "matrix": "/matrix/",
            "login": "/accounts/login/",
            "not_found": "/runs/999999/",
        }

    def efficiency_pages(self) -> dict[str, str]:
        """A failed build, scaling studies at two commits, timing breakdowns and two profiled runs (as in
        tests/web/test_dashboard_efficiency.py), and the pages that show them."""
        from datetime import timedelta

        from test_dashboard_efficiency import STACKS_A, STACKS_B, T0, TIMES, breakdown

        from harness.analysis import scaling
        from harness.store.models import Build, Run, Target, TestCase

        machine = self.s["ws1"]
        target = Target.objects.create(name="liggghts-src", definition={"recipe": "cmake"})
        case = TestCase.objects.create(path="liggghts/settling")
        builds, profiled = [], []
        for i, commit in enumerate(TIMES):
            build = Build.objects.create(target=target, machine=machine, revision="HEAD", commit=commit,
                                         definition_hash="d", status="complete", current=i == 1,
                                         committed_at=T0 + timedelta(days=i))
            builds.append(build)
            for point in scaling.expand({"name": "scaling", "script": "in.settling", "scaling": {"cores": [1, 2]}}):
                cores = point["scaling_point"]["cores"]
                Run.objects.create(machine=machine, target=target, build=build, testcase=case, name=point["name"],
                                   state="post_processed", config=point, stepping_time=TIMES[commit][cores],
                                   breakdown=breakdown(TIMES[commit][cores] * 0.8, 0.5, cores, 0.3 * (cores - 1)))
        for build, stacks, pair in ((builds[0], STACKS_A, 1.0), (builds[1], STACKS_B, 3.0)):
            folder = self.root / f"profile-{build.commit[:4]}"
            folder.mkdir()
            (folder / "profile.folded").write_text(stacks)
            profiled.append(Run.objects.create(
                machine=machine, target=target, build=build, testcase=case, name="serial", state="post_processed",
                config={"name": "serial"}, stepping_time=pair + 0.6, breakdown=breakdown(pair, 0.5),
                folder=str(folder), profile="profile.folded"))
        error = "../src/src/finish.cpp:722:40: error: ordered comparison of pointer with integer zero"
        failed = Build.objects.create(
            target=target, machine=machine, revision="3.8.0", commit="f" * 40, definition_hash="d",
            status="failed", started=T0 + timedelta(days=3), finished=T0 + timedelta(days=3, seconds=312.5),
            log="[ 40%] Building CXX object finish.cpp.o\n" + error + "\nmake: *** [all] Error 2\n",
            details={"recipe": "cmake", "error": error, "duration_s": 312.5, "jobs": 2,
                     "compiler": "c++ (Debian 12.2.0-14) 12.2.0",
                     "cmake_options": {"CMAKE_BUILD_TYPE": "Release", "ENABLE_VTK": "OFF"}, "patches": []})
        a, b = profiled
        return {
            "overview_failed_build": "/",
            "build_failed": f"/builds/{failed.pk}/",
            "build_complete": f"/builds/{builds[1].pk}/",
            "scaling": "/scaling/",
            "scaling_build": f"/scaling/?build={builds[0].pk}",
            "breakdown": f"/breakdown/{target.pk}/{case.path}/",
            "run_with_breakdown": f"/runs/{b.pk}/",
            "compare_with_breakdown": f"/compare/?run={a.pk}&run={b.pk}",
            "profile": f"/runs/{b.pk}/profile/",
            "profile_diff": f"/profiles/diff/?run={a.pk},{b.pk}",
        }

    def test_every_page_at_desktop_and_phone_width(self):
        page = self.page
        problems = []
        pages = {**self.pages(), **self.efficiency_pages()}
        for width in WIDTHS:
            page.set_viewport_size({"width": width, "height": 900})
            for name, url in pages.items():
                response = page.goto(self.live_server_url + url)
                assert response.status in (200, 404), f"{name}: HTTP {response.status}"
                if page.locator("#flamegraph").count():
                    page.wait_for_function("() => document.getElementById('flamegraph').dataset.drawn === '1'")
                    page.wait_for_timeout(800)  # d3-flame-graph's transitions
                self.screenshot(f"layout_{name}_{width}.png")
                broken = page.evaluate(BROKEN_WORDS)
                if broken:
                    problems.append(f"{name} at {width} px: words broken in table cells: {broken}")
                scroll = page.evaluate("() => document.documentElement.scrollWidth")
                if scroll > width:
                    problems.append(f"{name} at {width} px: the page is {scroll} px wide, it scrolls sideways: "
                                    f"{page.evaluate(OVERFLOWING, width)}")
        assert not problems, "\n".join(problems)

    def test_axis_titles_clear_the_tick_labels_on_every_plot(self):
        from harness.store.models import Run

        page = self.page
        errors = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        # stepping times of two commits as the bundled engine's oscillator has them: their log axis leaves
        # some of its splits out (null), which the tick labels must survive
        for key, stepping, wall in (("older", 0.2193, 3.60), ("inconsistent", 1.0432, 5.22)):
            Run.objects.filter(pk=self.s[key].pk).update(stepping_time=stepping, wall_time=wall)
        pages = {**self.pages(), **self.efficiency_pages()}
        plotted = {name: pages[name] for name in ("run", "consistency", "compare", "history", "scaling",
                                                  "scaling_build")}
        problems, axes = [], 0
        for width in WIDTHS:
            page.set_viewport_size({"width": width, "height": 900})
            for name, url in plotted.items():
                page.goto(self.live_server_url + url)
                page.wait_for_function("() => [...document.querySelectorAll('[data-plots]')]"
                                       ".every(b => b.dataset.drawn !== undefined)")
                drawn = page.evaluate("() => document.querySelectorAll('figure.chart').length")
                assert drawn, f"{name}: no plots drawn"
                axes += page.evaluate("() => [...document.querySelectorAll('figure.chart')]"
                                      ".reduce((n, f) => n + f.uplot.axes.filter(a => a.label).length, 0)")
                problems += [f"{name} at {width} px: {p}" for p in page.evaluate(AXIS_OVERLAPS)]
        assert not errors, errors
        assert axes > 20 and not problems, "\n".join(problems)

    def test_the_axis_check_catches_tick_labels_under_the_title(self):
        """The axis check can fail: the y axis of a run's plot squeezed to 20 px under labels like 0.0010."""
        page = self.page
        page.goto(self.live_server_url + f"/runs/{self.s['inconsistent'].pk}/")
        assert self.charts_drawn("#run-plots")
        assert page.evaluate(AXIS_OVERLAPS) == []
        page.evaluate("""() => { const u = document.querySelector('figure.chart').uplot;
                                 u.axes[1].size = () => 20; u.setSize({width: u.width - 10, height: u.height}); }""")
        assert any("axis 1" in p for p in page.evaluate(AXIS_OVERLAPS))

    def test_the_checks_catch_a_broken_word_and_a_wide_page(self):
        """The two checks above can fail: a narrow cell breaking a long word, and a wide block."""
        page = self.page
        page.set_viewport_size({"width": 390, "height": 900})
        page.goto(self.live_server_url + "/")
        page.evaluate("""() => {
          const t = document.createElement('table');
          t.innerHTML = '<tr><td style="width:3em;max-width:3em;overflow-wrap:anywhere;white-space:normal">' +
                        'averyveryverylongword</td></tr>';
          document.querySelector('main').appendChild(t);
          const d = document.createElement('div'); d.style.width = '900px'; d.textContent = 'wide';
          document.querySelector('main').appendChild(d);
        }""")
        assert page.evaluate(BROKEN_WORDS)
        assert page.evaluate("() => document.documentElement.scrollWidth") > 390


@pytest.fixture(autouse=True)
def _artifacts():
    ARTIFACTS.mkdir(exist_ok=True)
