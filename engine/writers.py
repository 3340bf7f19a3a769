"""Writers: thermo/print CSV files, VTK PolyData dumps, restart files, timing JSON.

Every CSV row is flushed as soon as it is written, so a run that crashes leaves valid files behind. Numbers
are written with ``repr`` (shortest exact round trip): two runs agree byte for byte iff their values do.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np


class CsvSeries:
    """A CSV file with a header and one row per output step; a step already written is not repeated."""

    def __init__(self, path: str, columns: list[str]):
        self.path = Path(path)
        self.columns = columns
        if self.path.parent != Path(""):
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self.handle = open(self.path, "w", buffering=1)
        self.handle.write(",".join(columns) + "\n")
        self.handle.flush()
        self.last_step = None

    def write(self, step: int, values: list):
        if step == self.last_step:
            return
        self.last_step = step
        self.handle.write(",".join(_format(v) for v in values) + "\n")
        self.handle.flush()

    def close(self):
        self.handle.close()


def _format(value) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def write_vtp(path: Path, ids, types, x, v, f, omega, radius):
    """Particles as VTK PolyData (.vtp, ParaView): points with vertex cells and per-point data arrays.

    Arrays: id, type (user numbering, from 1), velocity (m/s), force (N), omega (rad/s), radius (m).
    """
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray

    n = len(ids)
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(x, dtype=np.float64), deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(points)
    cells = vtk.vtkCellArray()
    cells.SetData(numpy_to_vtkIdTypeArray(np.arange(n + 1, dtype=np.int64), deep=True),
                  numpy_to_vtkIdTypeArray(np.arange(n, dtype=np.int64), deep=True))
    poly.SetVerts(cells)
    data = poly.GetPointData()
    for name, values in (("id", np.asarray(ids, dtype=np.int64)), ("type", np.asarray(types, dtype=np.int32)),
                         ("velocity", v), ("force", f), ("omega", omega), ("radius", radius)):
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        array.SetName(name)
        data.AddArray(array)
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(poly)
    writer.SetDataModeToBinary()
    if not writer.Write():
        raise OSError(f"cannot write VTK file {path}")


def write_timing(path: str, timing: dict):
    """timing.json: pair, neigh, comm, modify, output, other, total (s), steps, particles, particle_steps_per_second."""
    Path(path).write_text(json.dumps(timing, indent=1) + "\n")
