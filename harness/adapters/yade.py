"""Adapter for YADE (Debian package ``yade``: ``/usr/bin/yade``, 2023.02a), scripted in Python.

A run is a YADE Python script started in batch mode (no GUI, exit when the script ends) with the
run.config's ``variables`` as ``NAME=VALUE`` script arguments::

    /usr/bin/python3.11 harness/adapters/yade_support/launch.py --log log.yade /usr/bin/yade scene.py steps=1000

``launch.py`` loads the YADE launcher as a module (YADE's documented way to use it from Python) so that no
TCP server is started: ``yade -n -x`` opens a Python prompt on port 9000 and an info server on 21000 (or the
next free ones) for every run, which parallel runs do not need. When the executable is not a Python file
(a wrapper of another build), the adapter falls back to ``env PYTHONPATH=yade_support yade -n -x script.py ARG ...``.

YADE prints no thermo table, so a script reports through the helper ``yade_series`` (importable in any script
the harness runs, ``harness/adapters/yade_support/yade_series.py``): ``thermo.csv`` (step, time, atoms, ke,
rke, J, velocity-Verlet full-step velocities) and ``timing.json`` (s), the files the bundled engine writes.
A script that does not use the helper (YADE's examples) gets one row of its final state from the launcher.
Errors: the launcher's ``ERROR: ...`` line for an exception of the script, YADE's ``<ERROR>``/``<FATAL>`` log
lines; warnings: ``<WARNING>`` lines. Dumps: ``VTKRecorder`` files (``PREFIXspheres.ITER.vtu``) are
converted to ``vtk/spheres_ITER.vtp`` with the array names the harness reads (v, omega, radius, mass).
"""
from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

from harness.adapters import register
from harness.adapters.base import EngineAdapter, LogScan, UserError
from harness.execution.postprocess import read_vtk_dataset

LOG_NAME = "log.yade"
SUPPORT = Path(__file__).resolve().parent / "yade_support"
LAUNCHER = SUPPORT / "launch.py"
TIMING_KEYS = ("pair", "neigh", "comm", "modify", "output", "other", "total")
#: VTKRecorder array names -> the names harness.execution.postprocess reads
VTK_ARRAYS = {"linVelVec": "v", "angVelVec": "omega", "radii": "radius", "mass": "mass", "ids": "id"}
_SPHERES = re.compile(r"spheres\.(\d+)\.vtu$")


def python_of(executable: str) -> str | None:
    """The interpreter of a YADE launcher that is a Python file (its ``#!`` line), else None."""
    try:
        with open(executable, "rb") as handle:
            first = handle.readline(200).decode("utf-8", "replace").strip()
    except OSError:
        return None
    if first.startswith("#!") and "python" in first:
        words = first[2:].split()
        if words and Path(words[0]).name == "env" and len(words) > 1:
            return words[1]
        return words[0] if words else None
    return None


def convert_vtu(source: Path, destination: Path) -> None:
    """A VTKRecorder ``spheres`` file (UnstructuredGrid) as PolyData with the harness' array names."""
    # a heavy library, loaded when this runs, not at every `harness` start
    import vtk

    grid = read_vtk_dataset(vtk.vtkXMLUnstructuredGridReader(), source,
                            f"{source}: not a readable VTK UnstructuredGrid file")
    poly = vtk.vtkPolyData()
    if grid is not None:
        poly.SetPoints(grid.GetPoints())
        data = grid.GetPointData()
        for i in range(data.GetNumberOfArrays()):
            array = data.GetArray(i)
            if array is None or not array.GetName():
                continue
            copy = array.NewInstance()
            copy.DeepCopy(array)
            copy.SetName(VTK_ARRAYS.get(array.GetName(), array.GetName()))
            poly.GetPointData().AddArray(copy)
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(str(destination))
    writer.SetInputData(poly)
    if not writer.Write():
        raise UserError(f"{destination}: VTK writer failed")


@register
class YadeAdapter(EngineAdapter):
    #: YADE parallelises with OpenMP threads (OMP_NUM_THREADS), not MPI ranks
    parallelism = "threads"
    """YADE: batch command line, thermo.csv/timing.json written by the yade_series helper, VTKRecorder dumps."""

    name = "yade"
    thermo_file = "thermo.csv"
    timing_file = "timing.json"
    vtk_folder = "vtk"

    def command(self, executable, script, variables, log, mpi=None):
        """``[python launch.py --log LOG YADE] script NAME=VALUE ...``; an mpi run is refused with a reason."""
        executable = list(executable)
        arguments = [f"{name}={value}" for name, value in (variables or {}).items()]
        python = python_of(executable[0]) if len(executable) == 1 else None
        if python is None:
            # not a Python launcher: YADE's own batch mode (it opens its TCP servers on free ports), with the
            # helper's folder as PYTHONPATH so that 'import yade_series' works there too
            return ["env", f"PYTHONPATH={SUPPORT}"] + executable + ["-n", "-x", script] + arguments
        prefix = [python, str(LAUNCHER), "--log", log]
        if mpi:
            prefix += ["--refuse", "run type mpi: the harness runs YADE serially, with one OpenMP thread; "
                                   "use type serial"]
        return prefix + executable + [script] + arguments

    def log_file(self) -> str:
        return LOG_NAME

    def accepts_script(self, script: str) -> bool:
        """YADE scripts are Python files."""
        return script.endswith(".py")

    def read_thermo(self, folder, mapping=None):
        """thermo.csv of the yade_series helper: step, time, atoms, ke (J), rke (J), extra columns."""
        # a heavy library, loaded when this runs, not at every `harness` start
        import pandas as pd

        path = Path(folder) / self.thermo_file
        if not path.is_file():
            raise UserError(f"{path}: no thermo output (a YADE script writes it with the yade_series helper, "
                            "docs/yade.md)")
        try:
            table = pd.read_csv(path, skipinitialspace=True, encoding_errors="replace")
        except (pd.errors.EmptyDataError, pd.errors.ParserError) as exc:
            raise UserError(f"{path}: unreadable ({str(exc).splitlines()[0]})") from None
        if table.empty:
            raise UserError(f"{path}: header only, no thermo rows")
        return self.map_thermo(table, mapping, str(path))

    def read_timing(self, folder):
        """timing.json of the helper (s): total, pair, neigh, comm, modify, output, other (missing ones 0)."""
        path = Path(folder) / self.timing_file
        try:
            data = json.loads(path.read_text(encoding="utf-8", errors="replace"))
        except (OSError, ValueError):
            data = {}
        timing = {key: 0.0 for key in TIMING_KEYS}
        if isinstance(data, dict):
            for key, value in data.items():
                if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
                    timing[key] = float(value)
        return timing

    def scan_log(self, folder) -> LogScan:
        """``ERROR`` lines (the launcher's, one per failed script) and YADE's ``<ERROR>``/``<FATAL>`` log lines
        from the log, stdout and stderr, once each; ``<WARNING>`` lines as warnings."""
        folder = Path(folder)
        scan = LogScan()
        sources = [folder / self.log_file()] + sorted(p for p in folder.glob("std*") if p.is_file())
        for source in sources:
            if not source.is_file():
                continue
            for line in source.read_text(errors="replace").splitlines():
                text = line.strip()
                if text.startswith(("ERROR", "<ERROR>", "<FATAL>")):
                    if text not in scan.errors:
                        scan.errors.append(text)
                elif text.startswith(("WARNING", "<WARNING>")) and text not in scan.warnings:
                    scan.warnings.append(text)
        return scan

    def vtk_files(self, folder):
        """VTKRecorder sphere files of the run, converted to ``vtk/spheres_ITER.vtp``, by iteration."""

        folder = Path(folder)
        sources = sorted((int(m.group(1)), p) for p in folder.rglob("*.vtu")
                         if (m := _SPHERES.search(p.name)) and self.vtk_folder not in p.relative_to(folder).parts)
        if not sources:
            return []
        target = folder / self.vtk_folder
        if target.is_dir():
            shutil.rmtree(target)
        target.mkdir()
        files = []
        for step, path in sources:
            out = target / f"spheres_{step}.vtp"
            if out in files:
                continue
            convert_vtu(path, out)
            files.append(out)
        return files

    def default_run_config(self, folder):
        """One serial run per ``*.py`` script of a folder without run.config (YADE's examples), or None."""
        scripts = sorted(p.name for p in Path(folder).glob("*.py") if p.is_file())
        if not scripts:
            return None
        return {"runs": [{"name": name[:-3], "type": "serial", "script": name} for name in scripts]}
