"""Writers: thermo/print CSV files, VTK PolyData dumps, restart files, timing JSON.

Every CSV row is flushed as soon as it is written, so a run that crashes leaves valid files behind. Numbers
are written with ``repr`` (shortest exact round trip): two runs agree byte for byte iff their values do.
A file that cannot be written (missing permission, a folder in the way, a full disk) raises RunFailure naming
the file and the system's reason, never a bare OSError.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .errors import output_failure


class CsvSeries:
    """A CSV file with a header and one row per output step; a step already written is not repeated."""

    def __init__(self, path: str, columns: list[str], what: str = "CSV file"):
        self.path = Path(path)
        self.what = what
        self.columns = columns
        self.handle = None
        self.last_step = None
        try:
            if self.path.parent != Path(""):
                self.path.parent.mkdir(parents=True, exist_ok=True)
            self.handle = open(self.path, "w", buffering=1, encoding="utf-8")
        except OSError as exc:
            raise output_failure(what, path, exc) from None
        self._put(",".join(_header(c) for c in columns) + "\n")

    def _put(self, text: str):
        try:
            self.handle.write(text)
            self.handle.flush()
        except OSError as exc:
            self.close()
            raise output_failure(self.what, self.path, exc) from None

    def write(self, step: int, values: list):
        if step == self.last_step or self.handle is None:
            return
        self.last_step = step
        self._put(",".join(_format(v) for v in values) + "\n")

    def close(self):
        """Close once; a failed final flush was already reported by the write that failed first."""
        handle, self.handle = self.handle, None
        if handle is not None:
            try:
                handle.close()
            except OSError:
                pass


def _header(column: str) -> str:
    """A column name as a CSV field: quoted (RFC 4180) when it holds a comma or a quote, as a selection
    quantity such as ke[type=1,region=bin] does; every other name is written as it is."""
    if "," in column or '"' in column:
        return '"' + column.replace('"', '""') + '"'
    return column


def _format(value) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def write_vtp(path: Path, ids, types, x, v, f, omega, radius, extra=None):
    """Particles as VTK PolyData (.vtp, ParaView): points with vertex cells and per-point data arrays.

    Arrays: id, type (user numbering, from 1), velocity (m/s), force (N), omega (rad/s), radius (m), and the
    arrays of `extra` (name -> values; clump scenes: `body`, the body id of each member sphere).
    """
    # the few VTK modules a PolyData file needs: `import vtk` loads all of VTK (about 110 MB more memory)
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    from vtkmodules.vtkCommonCore import vtkObject, vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
    from vtkmodules.vtkCommonMisc import vtkErrorCode
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    n = len(ids)
    points = vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(x, dtype=np.float64), deep=True))
    poly = vtkPolyData()
    poly.SetPoints(points)
    cells = vtkCellArray()
    cells.SetData(numpy_to_vtkIdTypeArray(np.arange(n + 1, dtype=np.int64), deep=True),
                  numpy_to_vtkIdTypeArray(np.arange(n, dtype=np.int64), deep=True))
    poly.SetVerts(cells)
    data = poly.GetPointData()
    for name, values in (("id", np.asarray(ids, dtype=np.int64)), ("type", np.asarray(types, dtype=np.int32)),
                         ("velocity", v), ("force", f), ("omega", omega), ("radius", radius),
                         *(extra or {}).items()):
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        array.SetName(name)
        data.AddArray(array)
    try:
        # opening it here first gives the system's reason (VTK only reports a code) for a path that cannot be
        # a file
        open(path, "wb").close()
    except OSError as exc:
        raise output_failure("VTK dump", path, exc) from None
    writer = vtkXMLPolyDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(poly)
    writer.SetDataModeToBinary()
    # VTK prints its own multi-line error report on stderr; the engine reports one ERROR line instead
    shown = vtkObject.GetGlobalWarningDisplay()
    vtkObject.GlobalWarningDisplayOff()
    try:
        ok = writer.Write()
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)
    if not ok:
        code = writer.GetErrorCode()
        reason = (os.strerror(code) if 0 < code < vtkErrorCode.FirstVTKErrorCode
                  else vtkErrorCode.GetStringFromErrorCode(code))
        raise output_failure("VTK dump", path, OSError(code, reason))


def write_timing(path: str, timing: dict):
    """timing.json: pair, neigh, comm, modify, output, other, total (s), steps, particles, particle_steps_per_second."""
    try:
        Path(path).write_text(json.dumps(timing, indent=1) + "\n")
    except OSError as exc:
        raise output_failure("timing file", path, exc) from None
