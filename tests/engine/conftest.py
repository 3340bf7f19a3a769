"""Helpers: write a scene script into a temp folder and run the real engine on it.

Physics tests run the engine in-process (``engine.__main__.run``, the same code path as the program, minus
interpreter start-up) so compiled kernels are reused across tests; CLI tests run real subprocesses.
"""
from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def material(t=1, y=1e7, nu=0.3, rho=2500.0):
    return {"command": "create", "object": "material", "type": t, "youngs_modulus": y, "poisson_ratio": nu,
            "density": rho}


def interaction(types=(1, 1), e=0.5, mu=0.0, **extra):
    return {"command": "create", "object": "interaction", "types": list(types), "restitution": e, "friction": mu,
            **extra}


def domain(lo=(-1, -1, -1), hi=(1, 1, 1), periodic=(False, False, False)):
    return {"command": "create", "object": "domain", "lo": list(lo), "hi": list(hi), "periodic": list(periodic)}


def model(normal="hertz", tangential="history", **extra):
    return {"command": "create", "object": "contact_model", "normal": normal, "tangential": tangential, **extra}


def plane(name, axis, position, t=1, velocity=(0, 0, 0)):
    return {"command": "create", "object": "wall", "name": name, "shape": "plane", "axis": axis,
            "position": position, "type": t, "velocity": list(velocity)}


def particle(position, radius=0.01, velocity=(0, 0, 0), omega=(0, 0, 0), t=1):
    return {"command": "create", "object": "particle", "type": t, "radius": radius, "position": list(position),
            "velocity": list(velocity), "omega": list(omega)}


def gravity(g=(0, 0, -9.81)):
    return [{"command": "create", "object": "modifier", "name": "gravity", "kind": "gravity",
             "acceleration": list(g)}, {"command": "fix", "name": "gravity"}]


def timestep(dt):
    return {"command": "set", "property": "timestep", "value": dt}


def printer(every, quantities, file="series.csv", name="series"):
    return [{"command": "create", "object": "modifier", "name": name, "kind": "print", "every": every,
             "file": file, "quantities": quantities}, {"command": "fix", "name": name}]


def run(steps):
    return {"command": "run", "steps": steps}


def read_csv(path) -> dict:
    with open(path) as handle:
        rows = list(csv.reader(handle))
    return {name: np.array([float(r[k]) for r in rows[1:]]) for k, name in enumerate(rows[0])}


class Runner:
    def __init__(self, folder: Path):
        self.folder = folder

    def __call__(self, commands, variables=None, name="scene.json", sub=None):
        """Run commands in self.folder (or a sub folder); returns (exit code, folder)."""
        from engine.__main__ import run as run_engine

        folder = self.folder / sub if sub else self.folder
        folder.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(json.dumps(commands, indent=1))
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            code = run_engine(name, "log.dem", {k: str(v) for k, v in (variables or {}).items()}, echo=False)
        finally:
            os.chdir(cwd)
        return code, folder


def engine_program(folder, commands, *args, env=None, name="scene.json"):
    """Run the engine as a program on commands (written to folder/name) with the parallel loops forced on
    however few the particles (DEM_SERIAL_BELOW=0); env adds variables (e.g. NUMBA_NUM_THREADS)."""
    import subprocess
    import sys

    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(json.dumps(commands))
    full_env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_NUM_THREADS", "PYTHONPATH")}
    full_env.update(PYTHONPATH=str(REPO), DEM_SERIAL_BELOW="0", **(env or {}))
    return subprocess.run([sys.executable, "-m", "engine", "-in", name, *args], cwd=folder, env=full_env,
                          capture_output=True, text=True, timeout=900)


@pytest.fixture
def engine_run(tmp_path):
    return Runner(tmp_path)
