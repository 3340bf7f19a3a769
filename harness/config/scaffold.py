"""``harness new testcase NAME``: a working test case to start from - a sphere bouncing off a floor with the
bundled engine, and one expectation that holds.

The scene: a sphere (radius 5 mm) hits a Hooke wall at 1 m/s, no gravity; the Hooke damping is chosen so that
the coefficient of restitution is exactly ``E`` for a linear spring-dashpot, so after the contact the sphere
moves up at e x 1 m/s (the same physics as testcases/analytic/hooke_wall_restitution). The expectation says
so: ``thermo.vz[1]`` at the end is 0.9 m/s within 1 %.
"""
from __future__ import annotations

import json
from pathlib import Path

from harness.adapters.base import UserError
from harness.execution.workspace import segment_problem

SCENE = [
    {"command": "create", "object": "domain", "lo": [-0.05, -0.05, -0.05], "hi": [0.05, 0.05, 0.05]},
    {"command": "create", "object": "material", "type": 1, "youngs_modulus": 5e6, "poisson_ratio": 0.3,
     "density": 2500},
    {"command": "create", "object": "interaction", "types": [1, 1], "restitution": "${E}"},
    {"command": "create", "object": "contact_model", "normal": "hooke", "tangential": "none",
     "characteristic_velocity": 1.0},
    {"command": "create", "object": "wall", "name": "floor", "shape": "plane", "axis": "z", "position": 0.0,
     "type": 1},
    {"command": "create", "object": "particle", "type": 1, "radius": 0.005, "position": [0, 0, 0.0051],
     "velocity": [0, 0, -1.0]},
    {"command": "set", "property": "timestep", "value": "${DT}"},
    {"command": "set", "property": "thermo", "every": 10, "columns": ["z[1]", "vz[1]", "contacts"]},
    {"command": "run", "steps": "${STEPS}"},
]


def run_config(name: str) -> dict:
    return {
        "description": f"{name}: a sphere hits a Hooke floor at 1 m/s and bounces back at e x 1 m/s (written by "
                       "'harness new testcase'; see docs/run-config.md for every field).",
        "runs": [{
            "name": "bounce", "script": "scene.json", "variables": {"E": 0.9, "DT": 1e-5, "STEPS": 400},
            "expectations": [{"quantity": "thermo.vz[1]", "at": "end", "value": 0.9, "rel_tol": 0.01}],
        }],
    }


def new_testcase(parent: Path, name: str) -> list[Path]:
    """Write the bounce test case into ``parent/name`` (``name``: folders separated by '/', each a safe name;
    the folder must not exist yet); returns the files written."""
    for part in name.split("/"):
        problem = segment_problem(part)
        if problem:
            raise UserError(f"test case name {name!r}: {problem}")
    folder = parent / name
    if folder.exists():
        raise UserError(f"{folder}: exists already; choose a new name (nothing was written)")
    folder.mkdir(parents=True)
    files = {folder / "run.config": json.dumps(run_config(folder.name), indent=1) + "\n",
             folder / "scene.json": "[\n" + ",\n".join(" " + json.dumps(c) for c in SCENE) + "\n]\n"}
    for path, text in files.items():
        path.write_text(text)
    return list(files)
