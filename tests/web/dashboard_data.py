"""A small but complete store for the dashboard tests, made through the ORM with real run folders.

Machine ws1; targets dem-v1 (the reference) and dem-master (two builds: an older and the current commit);
test cases contact_models/hertz/impact, contact_models/hooke/impact, packing/settle; runs in every state.
Only the older master build's run (``older``) is not of a current build.
"""
from __future__ import annotations

import json
import math
import shutil
import tempfile
from datetime import datetime, timedelta, timezone
from pathlib import Path

from django.contrib.auth import get_user_model
from django.test import TestCase as DjangoTestCase

from harness.store.models import (
    Build,
    ConsistencyResult,
    Machine,
    Run,
    Series,
    Target,
    TestCase,
)

T0 = datetime(2026, 1, 5, 12, 0, tzinfo=timezone.utc)


class FolderTestCase(DjangoTestCase):
    """A Django TestCase whose class has a throw-away folder ``root`` for its run folders (named
    ``folder_prefix...``), made before ``setUpTestData`` and removed after the class's tests."""

    folder_prefix = "dashboard-"

    @classmethod
    def setUpClass(cls):
        cls.root = Path(tempfile.mkdtemp(prefix=cls.folder_prefix))
        super().setUpClass()

    @classmethod
    def tearDownClass(cls):
        super().tearDownClass()
        shutil.rmtree(cls.root, ignore_errors=True)


class StoreTestCase(FolderTestCase):
    """A FolderTestCase with the store of ``make_store`` (``s``: its objects by name)."""

    @classmethod
    def setUpTestData(cls):
        cls.s = make_store(cls.root)
STEPS = list(range(0, 2001, 100))
LOG_WITH_MARKUP = "Step Atoms KinEng\n<script>alert('log')</script>\nLoop time of 1.5 on 1 procs\n"


def kinetic_energy(shift: float = 0.0) -> list[float]:
    """ke [J] of a decaying impact: 1e-3 exp(-step/800) (+ shift after step 1000)."""
    return [1e-3 * math.exp(-s / 800) + (shift if s >= 1000 else 0.0) for s in STEPS]


def thesis_consistency(values: list[float], reference: list[float]) -> tuple[float, float, float | None, str]:
    """(C, eps, first step out of the 10 % band, level) by thesis eqs. 4.2-4.4, computed independently."""
    eps = 0.1 * (max(reference) - min(reference)) / 2
    deltas = [0.1 * abs(x - r) / eps for x, r in zip(values, reference)]
    c = 1 - max(deltas)
    first_bad = next((STEPS[k] for k, d in enumerate(deltas) if d >= 0.10), None)
    level = "perfect" if c > 0.95 else "good" if c > 0.90 else "inconsistent"
    return c, eps, first_bad, level


def write_vtp(path: Path, n: int = 4) -> None:
    """A real VTK PolyData file with n particles (positions m, radius m)."""
    import vtk

    points = vtk.vtkPoints()
    radius = vtk.vtkDoubleArray()
    radius.SetName("radius")
    for i in range(n):
        points.InsertNextPoint(0.01 * i, 0.0, 0.0)
        radius.InsertNextValue(0.005)
    poly = vtk.vtkPolyData()
    poly.SetPoints(points)
    poly.GetPointData().AddArray(radius)
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(poly)
    writer.Write()


def make_run_folder(root: Path, run: Run, script_text: str, log_text: str = "", stderr: str = "") -> Path:
    folder = root / f"run-{run.pk}"
    (folder / "post").mkdir(parents=True, exist_ok=True)
    (folder / "in.impact.json").write_text(script_text)
    # the bundled engine's log (harness/adapters/dem.py log_file()); the targets here name no other engine
    (folder / "log.dem").write_text(log_text or f"log of {run.name}\nLoop time of 1.5 on 1 procs\n")
    (folder / "stdout.txt").write_text(f"stdout of run {run.pk}\n")
    (folder / "stderr.txt").write_text(stderr)
    (folder / "run.json").write_text(json.dumps({"name": run.name, "testcase": run.testcase.path}))
    (folder / "post" / "torque.csv").write_text("t,torqueZ\n0,0\n1,0.5\n")
    write_vtp(folder / "post" / "dump_100.vtp")
    run.folder = str(folder)
    run.save(update_fields=["folder"])
    return folder


def add_series(run: Run, ke: list[float]) -> None:
    Series.objects.create(run=run, kind="thermo", name="thermo", x_column="step",
                          columns={"step": STEPS, "atoms": [12] * len(STEPS), "ke": ke,
                                   "rke": [0.0] * len(STEPS)},
                          meta={"units": {"ke": "J", "rke": "J"}, "order": ["step", "atoms", "ke", "rke"]})
    Series.objects.create(run=run, kind="plot", name="torqueZ", x_column="t",
                          columns={"t": [s * 1e-5 for s in STEPS], "torqueZ": [k * 10 for k in ke]},
                          meta={"title": "Torque", "xlabel": "time_[s]", "ylabel": "torque_z_[Nm]",
                                "legend": ["torqueZ_(rotor)"], "order": ["t", "torqueZ"]})


#: test case content hashes (sha256 hex) the runs ran
CONTENT = {"contact_models/hertz/impact": "1e" * 32, "contact_models/hooke/impact": "2f" * 32,
           "packing/settle": "3a" * 32}
TIMING = {"pair": 0.8, "neigh": 0.3, "comm": 0.1, "modify": 0.1, "output": 0.1, "other": 0.1, "total": 1.5}


def make_store(root: Path) -> dict:
    """Fill the store; returns the objects the tests refer to by name."""
    ws1 = Machine.objects.create(name="ws1")
    ref_target = Target.objects.create(name="dem-v1", definition={"revision": "v1"})
    master = Target.objects.create(name="dem-master", definition={"revision": "HEAD"}, reference=ref_target)
    ref_build = Build.objects.create(target=ref_target, machine=ws1, revision="v1", commit="a" * 40,
                                     definition_hash="d1", status="complete", committed_at=T0,
                                     commit_message="release v1", log="build ok", current=True)
    old_build = Build.objects.create(target=master, machine=ws1, revision="HEAD~1", commit="b" * 40,
                                     definition_hash="d2", status="complete",
                                     committed_at=T0 + timedelta(days=1), commit_message="tune damping")
    new_build = Build.objects.create(target=master, machine=ws1, revision="HEAD", commit="c" * 40,
                                     definition_hash="d2", status="complete",
                                     committed_at=T0 + timedelta(days=2),
                                     commit_message="faster neighbor list", executable='["dem"]', current=True)
    hertz = TestCase.objects.create(path="contact_models/hertz/impact")
    hooke = TestCase.objects.create(path="contact_models/hooke/impact")
    settle = TestCase.objects.create(path="packing/settle")

    def run(target, build, case, name, state, **kw):
        return Run.objects.create(machine=ws1, target=target, build=build, testcase=case, name=name,
                                  testcase_hash=kw.pop("testcase_hash", CONTENT[case.path]),
                                  state=state, config={"name": name, "script": "in.impact.json",
                                                       "variables": {"dt": "1e-5"}, **kw.pop("config", {})},
                                  wall_time=kw.pop("wall_time", 1.5), timing=kw.pop("timing", TIMING),
                                  started=T0, **kw)

    ref_ke = kinetic_energy()
    reference = run(ref_target, ref_build, hertz, "serial", "post_processed")
    make_run_folder(root, reference, '{"run": 2000, "dt": 1e-5}\n')
    add_series(reference, ref_ke)

    # The newer master build drifts after step 1000: inconsistent with the reference.
    drifted_ke = kinetic_energy(shift=8e-5)
    c, eps, first_bad, level = thesis_consistency(drifted_ke, ref_ke)
    inconsistent = run(master, new_build, hertz, "serial", "consistency_checked", consistency=level,
                       consistency_min=c, reference_run=reference,
                       timing={**TIMING, "pair": 0.4, "total": 1.1}, wall_time=1.1)
    make_run_folder(root, inconsistent, '{"run": 2000, "dt": 2e-5}\n', log_text=LOG_WITH_MARKUP)
    add_series(inconsistent, drifted_ke)
    ConsistencyResult.objects.create(run=inconsistent, reference_run=reference, series_kind="thermo",
                                     series_name="thermo", quantity="ke", value=c, level=level, epsilon=eps,
                                     first_bad_step=first_bad)
    ConsistencyResult.objects.create(run=inconsistent, reference_run=reference, series_kind="thermo",
                                     series_name="thermo", quantity="atoms", value=1.0, level="perfect",
                                     epsilon=0.0)

    # The older master build of the same test case: consistent, and slower.
    older = run(master, old_build, hertz, "serial", "outdated", consistency="perfect", consistency_min=0.99,
                reference_run=reference, wall_time=2.0, timing={**TIMING, "total": 2.0, "other": 0.6})
    make_run_folder(root, older, '{"run": 2000, "dt": 1e-5}\n')
    add_series(older, ref_ke)

    failed = run(master, new_build, hooke, "serial", "failed", failure_reason="exit_code",
                 failure_message="engine exited with code 3", exit_code=3, wall_time=0.4,
                 timing={})
    make_run_folder(root, failed, '{"run": 2000}\n', stderr="Segmentation <fault> & core dumped\n")
    not_run = run(master, new_build, hooke, "mpi4", "not_executed", wall_time=None, timing={})
    good = run(master, new_build, settle, "serial", "consistency_checked", consistency="good",
               consistency_min=0.93, wall_time=3.0)
    make_run_folder(root, good, '{"run": 5000}\n')
    add_series(good, kinetic_energy())
    user = get_user_model().objects.create_user("reviewer", password="pw-for-tests-only")
    return {"ws1": ws1, "master": master, "ref_target": ref_target, "reference": reference,
            "inconsistent": inconsistent, "older": older, "failed": failed, "not_run": not_run, "good": good,
            "hertz": hertz, "hooke": hooke, "settle": settle, "new_build": new_build, "user": user,
            "c": c, "eps": eps, "first_bad": first_bad}


def add_bulk_runs(count: int, machine, target, build, prefix: str = "bulk") -> None:
    """``count`` more post-processed runs spread over 10 extra test cases (for query count tests)."""
    offset = Run.objects.count()  # unique run names when called again
    cases = [TestCase.objects.get_or_create(path=f"{prefix}/group{i % 3}/case{i}")[0] for i in range(10)]
    Run.objects.bulk_create([
        Run(machine=machine, target=target, build=build, testcase=cases[i % 10], name=f"r{offset + i}",
            state="post_processed" if i % 4 else "failed", wall_time=0.5, timing=TIMING,
            consistency="good" if i % 2 else "", consistency_min=0.92 if i % 2 else None)
        for i in range(count)])
