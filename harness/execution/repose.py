"""Dynamic angle of repose of a rotating drum, measured in a run folder of the bundled engine or LIGGGHTS.

The one home of the measurement the drum cases' post scripts make (``testcases/scenes/drum/angle.py``,
``testcases/shapes/drum_repose/angle.py``: each calls :func:`measure` with its scene's time step and
particle diameter). A post script runs in the run folder with the project on PYTHONPATH
(harness/execution/execute.py, ``_run_post_scripts``) and reads the run through the adapter of the code
that wrote it.

Geometry: the drum's axis is the y axis through the origin; the drum turns right-handed about +y, so its
bottom moves towards -x and the bed climbs on the -x side.

- ``angle_com`` (deg): from the bed's centre of mass (thermo columns ``com_x``, ``com_z`` of every row). A
  bed whose free surface is a plane chord of the circular section is a circular segment; its centroid lies on
  the segment's symmetry line, the radius perpendicular to the chord, so the surface's angle to the
  horizontal is the angle of the centroid's offset from the vertical: tan(theta) = -com_x / -com_z. The
  particle centres fill the segment shrunk by one radius from the mantle and the surface, which keeps the
  symmetry line, so the relation holds for the centres too (no fit, every particle used). A curved
  (S-shaped) surface, at higher Froude numbers than in our drums, makes it the angle of the chord between
  the surface's ends.
- ``angle_surface`` (deg): a line fitted to the free surface in the plane normal to the axis, per dump: in a
  frame turned by the dump's own centre-of-mass angle (u along the surface, w normal to it, up), the highest
  particle centre in each 1.5 d wide bin of u over the middle 60 % of the surface's length; a least-squares
  line w(u) turns the frame by atan(slope), and a second pass from there gives the dump's angle. Averaged
  over the dumps of the steady part. Clumps are dumped as their member spheres, whose centres are used.

Files written (in the run folder):

- ``angle.txt``: ``angle_com angle_surface``, means over the steady part t >= ``t_steady``;
- ``drum.csv``: window means over ``window`` s (from ``window_start``) of ke, rke (J), com_x, com_z (m) and
  the rows' angle_com (deg), the quantities a cross-code check scores (single rows of a granular flow are
  chaotic, window means are not: docs/scenes.md);
- ``angle_series.csv``: time (s) and angle_com (deg) of every thermo row, for plots.

ke is the thermo column ``kems`` when there is one (LIGGGHTS' ``compute ke/multisphere`` of multisphere
bodies, the scripts of testcases/shapes), else ``ke``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from harness.adapters import adapter_of_run
from harness.execution.postprocess import dump_step, read_vtk_points


def surface_angle(points: np.ndarray, guess_deg: float, diameter: float) -> float:
    """Angle (deg) of the free surface of one dump (particle centres, m), from the frame turned by guess_deg."""
    theta = math.radians(guess_deg)
    x, z = points[:, 0], points[:, 2]
    # the bed rises towards -x: u runs along the surface from its low end (+x) to its high end (-x),
    # w is the outward normal of the surface
    u = -x * math.cos(theta) + z * math.sin(theta)
    w = x * math.sin(theta) + z * math.cos(theta)
    top = w > np.percentile(w, 50)
    lo, hi = np.percentile(u[top], [5, 95])
    middle, half = 0.5 * (lo + hi), 0.3 * (hi - lo)
    edges = np.arange(middle - half, middle + half + 1e-12, 1.5 * diameter)
    us, ws = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (u >= a) & (u < b)
        if inside.any():
            k = np.argmax(np.where(inside, w, -np.inf))
            us.append(u[k])
            ws.append(w[k])
    slope = np.polyfit(us, ws, 1)[0]
    return guess_deg + math.degrees(math.atan(slope))


def window_means(time: np.ndarray, columns: list[np.ndarray], window: float, start: float = 0.0) -> list[list[float]]:
    """Rows (window centre, mean of each column) over consecutive windows (t, t + window] of time from ``start``."""
    rows = []
    while start + window <= time[-1] + 1e-9:
        inside = (time > start + 1e-12) & (time <= start + window + 1e-12)
        rows.append([start + 0.5 * window] + [float(c[inside].mean()) for c in columns])
        start += window
    return rows


def measure(folder: Path | str = ".", *, timestep: float, diameter: float, t_steady: float = 1.0,
            window: float = 0.5, window_start: float = 0.0) -> dict[str, float]:
    """Measure the run in ``folder`` and write angle.txt, drum.csv and angle_series.csv there.

    ``timestep`` (s) turns the thermo's steps into time (LIGGGHTS prints no time column), ``diameter`` (m) of
    the (member) spheres sets the surface fit's bins, ``t_steady`` (s) starts the steady part, ``window`` (s)
    is the length of drum.csv's windows (about one avalanche period), the first starting at ``window_start`` (s;
    later than 0 when particles are inserted at random, a fall no two runs share). Returns angle_com and angle_surface
    (deg) with their standard deviations over the rows and the dumps of the steady part.
    """
    folder = Path(folder)
    adapter = adapter_of_run(folder)
    thermo = adapter.read_thermo(folder)
    time = thermo["step"].to_numpy() * timestep
    com_x = thermo["com_x"].to_numpy()
    com_z = thermo["com_z"].to_numpy()
    angle = np.degrees(np.arctan2(-com_x, -com_z))
    steady = time >= t_steady - 1e-12
    angle_com = float(np.mean(angle[steady]))

    surface = []
    for path in adapter.vtk_files(folder):
        step = dump_step(path)
        if step is None or step * timestep < t_steady - 1e-12:
            continue
        points = read_vtk_points(path)["points"]
        if len(points) < 10:
            continue
        centre = points.mean(axis=0)
        guess = math.degrees(math.atan2(-centre[0], -centre[2]))
        surface.append(surface_angle(points, surface_angle(points, guess, diameter), diameter))
    angle_surface = float(np.mean(surface)) if surface else float("nan")

    with open(folder / "angle.txt", "w") as out:
        out.write("angle_com angle_surface\n")
        out.write(f"{angle_com:.3f} {angle_surface:.3f}\n")
    ke = thermo["kems" if "kems" in thermo.columns else "ke"].to_numpy()
    rke = thermo["rke"].to_numpy()
    with open(folder / "drum.csv", "w") as out:
        out.write("time,ke,rke,com_x,com_z,angle\n")
        for row in window_means(time, [ke, rke, com_x, com_z, angle], window, window_start):
            out.write(",".join(repr(v) for v in row) + "\n")
    with open(folder / "angle_series.csv", "w") as out:
        out.write("time,angle\n")
        for t, a in zip(time, angle):
            out.write(f"{float(t)!r},{float(a)!r}\n")
    return {"angle_com": angle_com, "angle_com_sd": float(np.std(angle[steady])), "rows": int(steady.sum()),
            "angle_surface": angle_surface, "angle_surface_sd": float(np.std(surface)) if surface else math.nan,
            "dumps": len(surface)}


def report(result: dict[str, float]) -> str:
    """The one line a post script prints: both angles with their spread."""
    return (f"angle_com {result['angle_com']:.2f} deg (sd {result['angle_com_sd']:.2f}, {result['rows']} rows), "
            f"angle_surface {result['angle_surface']:.2f} deg (sd {result['angle_surface_sd']:.2f}, "
            f"{result['dumps']} dumps)")
