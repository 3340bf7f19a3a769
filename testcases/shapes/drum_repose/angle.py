#!/usr/bin/env python3
"""Dynamic angle of repose of the rotating drum, from the run's thermo and dumps, in either code.

Runs in the run folder of the bundled engine or LIGGGHTS and reads the run through the harness adapter of the
code that wrote it. The drum's axis is the y axis through the origin; it turns right-handed about +y, so its
bottom moves towards -x and the bed climbs on the -x side. Writes:

- angle.txt: ``angle_com angle_surface`` (degrees, means over the steady part t >= T_STEADY):
  * angle_com: the bed's centre of mass (com_x, com_z of every thermo row). A bed whose free surface is a
    plane chord of the circular section is a circular segment; its centroid lies on the segment's symmetry
    line, the radius perpendicular to the chord, so the surface's angle to the horizontal is the angle of the
    centroid's offset from the vertical: tan(theta) = -com_x / -com_z. The particle centres fill the segment
    shrunk by one radius from the mantle and the surface, which keeps the symmetry line, so the relation
    holds for the centres too (it needs no fit and uses every particle). A curved (S-shaped) surface, at
    higher Froude numbers than here, makes it the angle of the chord between the surface's ends.
  * angle_surface: a line fitted to the free surface in the plane normal to the axis, per dump: in a frame
    turned by the dump's angle_com (u along the surface, w normal to it, up), the highest particle centre in
    each 1.5 d wide bin of u over the middle 60 % of the surface's length; a least-squares line w(u) turns
    the frame by atan(slope). Averaged over the dumps of the steady part.
- drum.csv: window means over WINDOW s of ke, rke (J), com_x, com_z (m) and the angle_com of the rows (deg):
  the quantities the cross-code check scores (single rows of a granular flow are chaotic; window means are
  not, see docs/scenes.md).
- angle_series.csv: time (s) and angle_com (deg) of every thermo row, for plots.
"""
import math
from pathlib import Path

import numpy as np

from harness.adapters import get_adapter
from harness.execution.postprocess import dump_step, read_vtk_points

T_STEADY = 1.0    # s, start of the steady part (the bed forms and first reaches its angle by 0.6 s)
WINDOW = 0.5      # s, about one avalanche period at omega = 2 rad/s
TIMESTEP = 2e-5   # s, both scripts' dt (LIGGGHTS prints no time column)
DIAMETER = 0.004  # m

here = Path(".")
code = "liggghts" if (here / "log.liggghts").is_file() else "dem"
adapter = get_adapter(code)
thermo = adapter.read_thermo(here)
time = thermo["step"].to_numpy() * TIMESTEP
com_x = thermo["com_x"].to_numpy()
com_z = thermo["com_z"].to_numpy()
angle = np.degrees(np.arctan2(-com_x, -com_z))
steady = time >= T_STEADY - 1e-12
angle_com = float(np.mean(angle[steady]))


def surface_angle(points: np.ndarray, guess_deg: float) -> float:
    """Angle (deg) of the free surface of one dump, from the frame turned by guess_deg."""
    theta = math.radians(guess_deg)
    x, z = points[:, 0], points[:, 2]
    # the bed rises towards -x: u runs along the surface from its low end (+x) to its high end (-x),
    # w is the outward normal of the surface
    u = -x * math.cos(theta) + z * math.sin(theta)
    w = x * math.sin(theta) + z * math.cos(theta)
    top = w > np.percentile(w, 50)
    lo, hi = np.percentile(u[top], [5, 95])
    middle, half = 0.5 * (lo + hi), 0.3 * (hi - lo)
    edges = np.arange(middle - half, middle + half + 1e-12, 1.5 * DIAMETER)
    us, ws = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (u >= a) & (u < b)
        if inside.any():
            k = np.argmax(np.where(inside, w, -np.inf))
            us.append(u[k])
            ws.append(w[k])
    slope = np.polyfit(us, ws, 1)[0]
    return guess_deg + math.degrees(math.atan(slope))


surface = []
for path in adapter.vtk_files(here):
    step = dump_step(path)
    if step is None or step * TIMESTEP < T_STEADY - 1e-12:
        continue
    points = read_vtk_points(path)["points"]
    if len(points) < 10:
        continue
    centre = points.mean(axis=0)
    guess = math.degrees(math.atan2(-centre[0], -centre[2]))
    surface.append(surface_angle(points, surface_angle(points, guess)))
angle_surface = float(np.mean(surface)) if surface else float("nan")

with open("angle.txt", "w") as out:
    out.write("angle_com angle_surface\n")
    out.write(f"{angle_com:.3f} {angle_surface:.3f}\n")

rke = thermo["rke"].to_numpy()
ke = thermo["ke"].to_numpy()
with open("drum.csv", "w") as out:
    out.write("time,ke,rke,com_x,com_z,angle\n")
    start = 0.0
    while start + WINDOW <= time[-1] + 1e-9:
        rows = (time > start + 1e-12) & (time <= start + WINDOW + 1e-12)
        values = [start + 0.5 * WINDOW] + [float(v[rows].mean()) for v in (ke, rke, com_x, com_z, angle)]
        out.write(",".join(repr(v) for v in values) + "\n")
        start += WINDOW
with open("angle_series.csv", "w") as out:
    out.write("time,angle\n")
    for t, a in zip(time, angle):
        out.write(f"{float(t)!r},{float(a)!r}\n")
print(f"angle_com {angle_com:.2f} deg (sd {np.std(angle[steady]):.2f}, {steady.sum()} rows), "
      f"angle_surface {angle_surface:.2f} deg (sd {np.std(surface) if surface else float('nan'):.2f}, "
      f"{len(surface)} dumps)")
