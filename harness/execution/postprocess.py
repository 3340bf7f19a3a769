"""Post-processing of a run folder (thesis 4.3.5): thermo, declared CSV series and plots, text files, VTK.

Everything here reads files only (no store), so a worker on another host can post-process a run and hand
back plain data. Series are returned as ``{"kind", "name", "x_column", "columns", "meta"}`` dicts, the
shape the store's ``Series`` model keeps.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from harness.adapters.base import UserError

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^[-+]?(nan|inf|infinity)$", re.IGNORECASE)


def is_number(word: str) -> bool:
    return bool(_NUMBER.match(word))


def _json_values(values) -> list:
    """A column as JSON-safe values: floats (ints kept), NaN/inf as None."""
    array = np.asarray(values)
    if array.dtype.kind in "iu":
        return array.tolist()
    if array.dtype.kind == "f":
        out = array.astype(float).tolist()
        return [v if math.isfinite(v) else None for v in out]
    return [str(v) for v in array.tolist()]


def frame_to_series(kind: str, name: str, frame: pd.DataFrame, x_column: str = "", meta=None) -> dict:
    """A series record; ``meta["order"]`` keeps the column order (PostgreSQL's jsonb does not keep key order,
    and a declared plot's legend follows its columns)."""
    return {"kind": kind, "name": name, "x_column": x_column,
            "columns": {str(c): _json_values(frame[c].to_numpy()) for c in frame.columns},
            "meta": {**(meta or {}), "order": [str(c) for c in frame.columns]}}


def non_finite_columns(frame: pd.DataFrame) -> list[str]:
    """Numeric columns holding NaN or infinity (a diverged simulation)."""
    bad = []
    for column in frame.columns:
        values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
        original_missing = frame[column].isna().to_numpy()
        if (~np.isfinite(values) & ~(np.isnan(values) & ~original_missing)).any():
            bad.append(str(column))
    return bad


def read_table(path: Path, columns: list[str] | None = None) -> pd.DataFrame:
    """A CSV or whitespace-separated numeric table (``#`` comments); a first row of words is the header.

    ``columns`` names the columns to keep: by header name when the file has a header, else by position
    (thesis listing 4.11 declares ``"columns": ["t", "torqueZ"]`` for a fix print file).
    """
    if not path.is_file():
        raise UserError(f"data file {path.name!r} not found in the run folder")
    lines = [line for line in path.read_text(encoding="utf-8", errors="replace").splitlines()
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise UserError(f"data file {path.name!r} is empty")
    split = (lambda line: [w for w in re.split(r"[,;\s]+", line.strip()) if w])
    first = split(lines[0])
    has_header = not all(is_number(word) for word in first)
    rows = [split(line) for line in (lines[1:] if has_header else lines)]
    width = len(first)
    bad = next((i for i, row in enumerate(rows) if len(row) != width), None)
    if bad is not None:
        raise UserError(f"data file {path.name!r}: row {bad + 1 + has_header} has {len(rows[bad])} values, "
                        f"expected {width}")
    try:
        data = np.array(rows, dtype=float).reshape(len(rows), width)
    except ValueError as exc:
        raise UserError(f"data file {path.name!r}: not numeric ({exc})") from None
    header = first if has_header else [str(i) for i in range(width)]
    frame = pd.DataFrame(data, columns=header)
    if columns:
        if has_header and all(c in header for c in columns):
            frame = frame[columns]
        elif len(columns) <= width:
            frame = frame.iloc[:, :len(columns)]
            frame.columns = columns
        else:
            raise UserError(f"data file {path.name!r} has {width} columns, {len(columns)} declared")
    return frame


def read_declared(folder: Path, data: dict) -> tuple[dict[str, pd.DataFrame], list[dict]]:
    """Declared series, plots and text files of a run (thesis 4.4.2-4.4.3).

    Returns the series frames by name (for acceptance checks) and the store series list.
    """
    frames: dict[str, pd.DataFrame] = {}
    stored: list[dict] = []
    for decl in data.get("series", []):
        frame = read_table(folder / decl["file"], decl.get("columns"))
        frames[decl["name"]] = frame
    for plot in data.get("plots", []):
        refs = [plot["xdata"]] + (plot["ydata"] if isinstance(plot["ydata"], list) else [plot["ydata"]])
        columns = {}
        for ref in refs:
            series_name, column = ref.split(".", 1)
            frame = frames.get(series_name)
            if frame is None or column not in frame.columns:
                raise UserError(f"plot {plot['name']!r}: {ref!r} not found (columns of {series_name!r}: "
                                f"{', '.join(frame.columns) if frame is not None else 'none'})")
            columns[ref] = frame[column].to_numpy()
        length = min(len(v) for v in columns.values())
        frame = pd.DataFrame({k: v[:length] for k, v in columns.items()})
        meta = {k: plot[k] for k in ("title", "xlabel", "ylabel", "legend") if k in plot}
        stored.append(frame_to_series("plot", plot["name"], frame, refs[0], meta))
    for item in data.get("textfiles", []):
        decl = item if isinstance(item, dict) else {"file": item}
        path = folder / decl["file"]
        if not path.is_file():
            raise UserError(f"text file {decl['file']!r} not found in the run folder")
        words = path.read_text(encoding="utf-8", errors="replace").split()
        frames[decl["file"]] = pd.DataFrame({"word": words})
        try:
            # a numeric table with a header ("e_measured e_expected" then numbers) is also available to
            # expectations under the file's stem: "restitution.e_measured" for restitution.txt
            frames[Path(decl["file"]).stem] = read_table(path)
        except UserError:
            pass
        meta = {k: decl[k] for k in ("rtol", "atol") if k in decl}
        stored.append({"kind": "textfile", "name": decl["file"], "x_column": "", "columns": {"words": words},
                       "meta": meta})
    return frames, stored


_STEP = re.compile(r"(\d+)(?=\.[A-Za-z]+$)")


def dump_step(path: Path) -> int | None:
    """The time step in a dump file name (``dump_1000.vtp`` -> 1000)."""
    match = _STEP.search(path.name)
    return int(match.group(1)) if match else None


def read_vtk_dataset(reader, path: Path, unreadable: str):
    """What the VTK ``reader`` reads from ``path``: None for a file with no points (a dump written before any
    particle was inserted), a UserError saying ``unreadable`` for a file it cannot read."""
    reader.SetFileName(str(path))
    reader.Update()
    output = reader.GetOutput()
    if output is None or output.GetPoints() is None:
        if output is not None and output.GetNumberOfPoints() == 0:
            return None
        raise UserError(unreadable)
    return output


def read_vtk_points(path: Path) -> dict[str, np.ndarray]:
    """Points and point data arrays of a ``.vtp`` (XML PolyData) or legacy ``.vtk`` file."""
    # a heavy library, loaded when this runs, not at every `harness` start
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    # LIGGGHTS writes dumps before particles are inserted: an empty file is data (0 particles), not a warning
    vtk.vtkObject.GlobalWarningDisplayOff()
    if path.suffix == ".vtp":
        reader = vtk.vtkXMLPolyDataReader()
    elif path.suffix == ".vtu":
        reader = vtk.vtkXMLUnstructuredGridReader()
    else:
        reader = vtk.vtkGenericDataObjectReader()
    output = read_vtk_dataset(reader, path, f"VTK file {path.name!r} could not be read")
    if output is None:
        return {"points": np.zeros((0, 3))}
    arrays = {"points": vtk_to_numpy(output.GetPoints().GetData()).reshape(-1, 3)}
    point_data = output.GetPointData()
    for i in range(point_data.GetNumberOfArrays()):
        array = point_data.GetArray(i)
        if array is not None and array.GetName():
            arrays[array.GetName()] = vtk_to_numpy(array)
    return arrays


def _velocity(arrays: dict) -> np.ndarray | None:
    for name in ("velocity", "v", "vel"):
        if name in arrays and arrays[name].ndim == 2 and arrays[name].shape[1] == 3:
            return arrays[name]
    if all(c in arrays for c in ("vx", "vy", "vz")):
        return np.column_stack([arrays["vx"], arrays["vy"], arrays["vz"]])
    return None


def vtk_aggregates(files: list[Path], density: float | None = None) -> pd.DataFrame:
    """One row per dump: step, particles, ke, vx/vy/vz (mean), bounding box.

    ``ke`` is the translational kinetic energy in J, sum_i m_i |v_i|^2 / 2, when masses are known: a
    ``mass`` array, or ``radius`` (m) with ``density`` (kg/m^3) from a ``density`` array or the run.config's
    ``"vtk": {"density": ...}`` (m = 4/3 pi r^3 rho). Otherwise ``ke`` is per unit mass, sum_i |v_i|^2 / 2
    in J/kg (column ``ke_per_mass`` is always given too), so that trajectories remain comparable.
    """
    rows = []
    masses_known = bool(files)
    for path in files:
        arrays = read_vtk_points(path)
        points = arrays["points"]
        count = len(points)
        velocity = _velocity(arrays)
        speed2 = (velocity ** 2).sum(axis=1) if velocity is not None else np.zeros(count)
        mass = None
        if "mass" in arrays:
            mass = arrays["mass"].reshape(-1)
        elif "radius" in arrays:
            rho = arrays["density"].reshape(-1) if "density" in arrays else density
            if rho is not None:
                mass = 4.0 / 3.0 * np.pi * arrays["radius"].reshape(-1) ** 3 * rho
        masses_known = masses_known and mass is not None
        row = {"step": dump_step(path) if dump_step(path) is not None else len(rows), "particles": count,
               "ke_per_mass": 0.5 * speed2.sum(),
               "ke": 0.5 * (mass * speed2).sum() if mass is not None else 0.5 * speed2.sum()}
        mean_v = velocity.mean(axis=0) if velocity is not None and count else np.full(3, np.nan)
        low = points.min(axis=0) if count else np.full(3, np.nan)
        high = points.max(axis=0) if count else np.full(3, np.nan)
        for axis, i in zip("xyz", range(3)):
            row[f"v{axis}_mean"] = mean_v[i]
            row[f"{axis}_min"] = low[i]
            row[f"{axis}_max"] = high[i]
        rows.append(row)
    columns = ["step", "particles", "ke", "ke_per_mass", "vx_mean", "vy_mean", "vz_mean",
               "x_min", "x_max", "y_min", "y_max", "z_min", "z_max"]
    frame = pd.DataFrame(rows, columns=columns).sort_values("step", kind="stable").reset_index(drop=True)
    # the unit of "ke" depends on the dumps: the dashboard labels its axis from these (run meta "units")
    frame.attrs["units"] = {"step": "1", "particles": "1", "ke": "J" if masses_known else "J/kg",
                            "ke_per_mass": "J/kg", **{f"v{a}_mean": "m/s" for a in "xyz"},
                            **{f"{a}_{end}": "m" for a in "xyz" for end in ("min", "max")}}
    return frame
