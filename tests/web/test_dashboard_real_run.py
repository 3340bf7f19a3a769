"""The dashboard over a real run: `harness run` drives Debian's LIGGGHTS, the run folder is imported into
the test store (as results from another machine would be), and every page of the run renders from it."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from django.test import TestCase

from harness.execution.workspace import PROJECT_ROOT

LIGGGHTS = Path("/usr/bin/liggghts")
pytestmark = [pytest.mark.liggghts,
              pytest.mark.skipif(not LIGGGHTS.exists(), reason="needs Debian liggghts at /usr/bin/liggghts")]


@pytest.fixture(scope="module")
def real_run_folder(tmp_path_factory) -> Path:
    home = tmp_path_factory.mktemp("real-home")
    env = {k: v for k, v in os.environ.items() if k not in ("DJANGO_SETTINGS_MODULE", "HARNESS_DATABASE_URL")}
    env["PYTHONPATH"] = str(PROJECT_ROOT)
    done = subprocess.run([sys.executable, "-c", "import sys; from harness.cli import main; sys.exit(main())",
                           "--home", str(home), "--machine", "ci-box", "run", "liggghts", "-k", "wall_impact"],
                          cwd=PROJECT_ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return home / "runs"


@pytest.fixture
def client_with_real_run(real_run_folder, request):
    request.instance.runs_root = real_run_folder


@pytest.mark.usefixtures("client_with_real_run")
class RealRunTest(TestCase):
    def test_pages_of_a_real_liggghts_run(self):
        from harness.store.records import import_folder

        runs, problems = import_folder(self.runs_root)
        assert problems == [] and len(runs) == 1
        run = runs[0]
        overview = self.client.get("/").content.decode()
        assert "machine ci-box" in overview and "liggghts" in overview
        assert '<span class="target-verdict passed">passed</span>' in overview
        html = self.client.get(f"/runs/{run.pk}/").content.decode()
        assert "log.liggghts" in html and "in.impact" in html
        assert "Loop time of" in html  # the LIGGGHTS log itself
        response = self.client.get(f"/runs/{run.pk}/plots.json")
        titles = [p["title"] for p in response.json()["plots"]]
        assert {"thermo: atoms", "thermo: ke"} <= set(titles)  # thermo atoms, ke at least
        vtk = re.search(r'href="(/runs/\d+/files/post/[^"]+\.vtk)"', html).group(1)
        assert b"".join(self.client.get(vtk).streaming_content).startswith(b"# vtk DataFile")
        compare = self.client.get(f"/compare/?run={run.pk}&run={run.pk}").content.decode()
        assert "Comparison of 1 run" in compare  # the same run twice is one run
