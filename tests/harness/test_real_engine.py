"""The bundled engine itself through the harness: exported from this repository's HEAD, run, post-processed.

Two targets build the same commit; the engine is deterministic, so every thermo quantity must be perfectly
consistent (C = 1) and the VTK aggregates must match the engine's particle count.
"""
import json
from pathlib import Path

import pytest

from harness.cli import main
from harness.execution.workspace import PROJECT_ROOT

SCENE = [
    {"command": "create", "object": "domain", "lo": [-0.03, -0.03, -0.01], "hi": [0.03, 0.03, 0.08],
     "periodic": [False, False, False]},
    {"command": "create", "object": "material", "type": 1, "youngs_modulus": 1e7, "poisson_ratio": 0.3,
     "density": 2500.0},
    {"command": "create", "object": "interaction", "types": [1, 1], "restitution": 0.5, "friction": 0.3},
    {"command": "create", "object": "contact_model", "normal": "hertz", "tangential": "history"},
    {"command": "create", "object": "wall", "name": "floor", "shape": "plane", "axis": "z", "position": 0.0,
     "type": 1, "velocity": [0, 0, 0]},
    {"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity", "acceleration": [0, 0, -9.81]},
    {"command": "fix", "name": "gravity"},
    {"command": "create", "object": "random_packing", "type": 1, "count": "${N}", "seed": 5, "radius_min": 0.002,
     "radius_max": 0.003, "region": {"shape": "cylinder", "center": [0, 0], "radius": 0.018, "z": [0.0, 0.06]}},
    {"command": "set", "property": "timestep", "value": 2e-5},
    {"command": "set", "property": "thermo", "every": 50},
    {"command": "create", "object": "modifier", "name": "dump", "kind": "vtk", "every": 150},
    {"command": "fix", "name": "dump"},
    {"command": "run", "steps": 300},
]


def test_bundled_engine_end_to_end(store, tmp_path):
    if not (PROJECT_ROOT / ".git").exists():
        pytest.skip("needs the project's git checkout")
    from harness.store.models import Run, Series

    case = tmp_path / "cases" / "pour"
    case.mkdir(parents=True)
    (case / "scene.json").write_text(json.dumps(SCENE))
    (case / "run.config").write_text(json.dumps({"runs": [
        {"name": "n30", "script": "scene.json", "variables": {"N": 30}, "vtk": {"density": 2500.0}}]}))
    targets = tmp_path / "targets"
    targets.mkdir()
    common = {"repository": str(PROJECT_ROOT), "revision": "HEAD", "testcases": [str(tmp_path / "cases")]}
    (targets / "head.json").write_text(json.dumps({**common, "reference": "head-again"}))
    (targets / "head-again.json").write_text(json.dumps(common))
    args = ["--machine", "m1", "--targets", str(targets)]
    assert main([*args, "run", "-j", "2"]) == 0
    junit = tmp_path / "junit.xml"
    assert main([*args, "check", "--junit", str(junit)]) == 0
    run = Run.objects.get(target__name="head")
    assert run.state == "consistency_checked" and run.consistency == "perfect" and run.consistency_min == 1.0
    thermo = Series.objects.get(run=run, kind="thermo").columns
    assert thermo["step"] == list(range(0, 301, 50)) and set(thermo["atoms"]) == {30}
    dumps = Series.objects.get(run=run, kind="vtk").columns
    assert dumps["step"] == [0, 150, 300] and dumps["particles"] == [30, 30, 30]
    assert run.timing["total"] > 0 and run.command[-2:] == ["-log", "log.dem"]
    assert Path(run.folder, "post", "particles_300.vtp").is_file() or any(Path(run.folder, "post").glob("*_300.vtp"))
