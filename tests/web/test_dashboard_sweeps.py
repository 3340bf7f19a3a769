"""The sweep page: error against run time and the observed order, from sweep-point runs in the store."""
from __future__ import annotations

from django.test import TestCase

from harness.config.sweep import expand
from harness.store.models import Build, Machine, Run, Series, Target
from harness.store.models import TestCase as Case

SPEC = {"variable": "DT", "values": [4e-4, 2e-4, 1e-4], "error": {"quantity": "thermo.z", "exact": 1.0}}


class SweepPageTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        machine = Machine.objects.create(name="ws")
        target = Target.objects.create(name="dem")
        cls.build = Build.objects.create(target=target, machine=machine, revision="HEAD", commit="c" * 40,
                                         definition_hash="d", status="complete")
        case = Case.objects.create(path="accuracy/oscillator")
        for point in expand({"name": "dt", "script": "scene.json", "sweep": SPEC}):
            dt = point["variables"]["DT"]
            run = Run.objects.create(machine=machine, target=target, build=cls.build, testcase=case,
                                     name=point["name"], state="post_processed", config=point,
                                     wall_time=1e-3 / dt)
            # a second-order error: 1 + 5e4 dt^2
            Series.objects.create(run=run, kind="thermo", name="thermo", x_column="step",
                                  columns={"step": [0, 100], "z": [0.0, 1.0 + 5e4 * dt**2]})

    def test_sweep_page_shows_table_and_order(self):
        response = self.client.get("/sweeps/")
        self.assertEqual(response.status_code, 200)
        html = response.content.decode()
        self.assertIn("dem on ws: accuracy/oscillator/dt", html)
        self.assertIn("observed order <strong>2.00</strong>", html)
        for value in ("0.0004", "0.0002", "0.0001"):
            self.assertIn(f"<td>{value}</td>", html)
        self.assertIn(f'data-plots="/sweeps/{self.build.pk}/accuracy/oscillator/dt.json"', html)

    def test_sweep_plots_are_log_log_json_and_unknown_sweeps_are_404(self):
        response = self.client.get(f"/sweeps/{self.build.pk}/accuracy/oscillator/dt.json")
        self.assertEqual(response.status_code, 200)
        cost, convergence = response.json()["plots"]
        self.assertTrue(cost["xlog"] and cost["ylog"])
        self.assertEqual(cost["xlabel"], "run time [s] (engine time stepping)")
        self.assertEqual(convergence["series"][0]["label"], "observed order 2.00")
        self.assertEqual(self.client.get(f"/sweeps/{self.build.pk}/accuracy/oscillator/nope.json").status_code, 404)

    def test_navigation_links_to_the_sweeps(self):
        self.assertIn('href="/sweeps/"', self.client.get("/").content.decode())
