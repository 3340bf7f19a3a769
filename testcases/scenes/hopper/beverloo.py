#!/usr/bin/env python3
"""The hopper's steady mass flow rate against Beverloo's correlation (post script of every hopper run).

Beverloo, Leniger and van de Velde (1961), Chem. Eng. Sci. 15, 260, for a circular orifice in a flat bottom:

    W = C rho_b sqrt(g) (D - k d)^(5/2)        C = 0.58, k = 1.4 (Nedderman et al. 1982: k = 1.5)

W the mass flow rate (kg/s), rho_b the bulk density of the bed (kg/m^3), g (m/s^2), D the orifice diameter and d
the particle diameter (m). Everything is read from the run's own files, nothing is assumed:

- D: twice the radius of the scene's region `orifice` (the mesh's orifice has that area, make_meshes.py);
  d: the number-mean diameter of the random packing, radius_min + radius_max (uniform radii); g: the
  gravity modifier; the volume of the region `bulk` - all from the commands echoed in log.dem.
- W: slope of a least-squares line through removed_mass[drain] (kg, cumulative, flow.csv every 0.01 s) over
  the steady window: from T_START = 0.3 s (the loose packing has collapsed onto the bottom by about 0.16 s
  and the mass in the silo falls linearly from then on) to the end of the run, or earlier once the mass in
  the silo has fallen to END_FRACTION = 0.6 of what it held at T_START (a low bed whose free surface's crater
  nears the orifice is no longer Beverloo's steady flow).
- rho_b: mass[region=bulk] / volume of `bulk` (a z-cylinder of radius 32 mm, 2 d from the mantle, z = 20 ...
  45 mm: above the flowing zone over the orifice, below the free surface), the mean over the first
  RHO_WINDOW = 0.1 s of the window, when the bed is highest (particles counted by their centres: an unbiased
  estimate of the bulk density away from walls).
- W_beverloo with C = 0.58, k = 1.5; C_fit = W / (rho_b sqrt(g) (D - 1.5 d)^(5/2)), the C that makes
  Beverloo's formula (k = 1.5) give the measured rate.

Rows accumulate along the chain of runs (depends_on copies post/ in): the row of this run joins the rows of
post/beverloo_rows.csv and both that file and beverloo.csv (columns D, d, W_measured, W_beverloo, C_fit,
rho_b, t_start, t_end, points) hold every orifice size run so far. With three sizes or more it also fits
C and k together (W^(2/5) linear in D: slope (C rho_b sqrt g)^(2/5), intercept -slope k d) into
beverloo_fit.txt (columns C, k, sizes).
"""
import csv
import json
import math
import re
from pathlib import Path

K_FIXED = 1.5
C_BEVERLOO = 0.58
T_START = 0.3          # s
END_FRACTION = 0.6     # of the silo's mass at T_START
RHO_WINDOW = 0.1       # s

COMMAND = re.compile(r"^command \d+ \(([^)]*)\): (\{.*\})\s*$")


def scene_commands(log: str) -> list[dict]:
    """The commands of the run as the engine echoed them (variables replaced)."""
    return [json.loads(m.group(2)) for m in map(COMMAND.match, log.splitlines()) if m]


def region_volume(region: dict) -> float:
    if region["shape"] == "box":
        return math.prod(h - l for l, h in zip(region["lo"], region["hi"]))
    return math.pi * region["radius"] ** 2 * (region["z"][1] - region["z"][0])


def read_flow(path: str) -> dict:
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    return {name: [float(r[i]) for r in rows[1:]] for i, name in enumerate(rows[0])}


def line_fit(x: list, y: list) -> tuple[float, float]:
    """Least-squares slope and intercept."""
    n = len(x)
    mx, my = sum(x) / n, sum(y) / n
    sxx = sum((a - mx) ** 2 for a in x)
    slope = sum((a - mx) * (b - my) for a, b in zip(x, y)) / sxx
    return slope, my - slope * mx


def measure() -> dict:
    commands = scene_commands(Path("log.dem").read_text(encoding="utf-8", errors="replace"))
    regions = {c["name"]: c for c in commands if c.get("object") == "region"}
    packing = next(c for c in commands if c.get("object") == "random_packing")
    gravity = next(c for c in commands if c.get("kind") == "gravity")
    orifice = 2.0 * regions["orifice"]["radius"]
    diameter = packing["radius_min"] + packing["radius_max"]
    g = math.sqrt(sum(a * a for a in gravity.get("acceleration", [0, 0, -9.81])))
    bulk_volume = region_volume(regions["bulk"])

    flow = read_flow("flow.csv")
    time, removed, silo, bulk = (flow["time"], flow["removed_mass[drain]"], flow["mass[region=silo]"],
                                 flow["mass[region=bulk]"])
    start = next(i for i, t in enumerate(time) if t >= T_START - 1e-9)
    end = start
    while end + 1 < len(time) and silo[end + 1] >= END_FRACTION * silo[start]:
        end += 1
    if end - start < 10:
        raise SystemExit(f"steady window too short: {end - start + 1} rows from t = {time[start]:g} s "
                         f"(the run must last until the silo holds less than {END_FRACTION} of its mass)")
    rate, _ = line_fit(time[start:end + 1], removed[start:end + 1])
    rho_rows = [m / bulk_volume for t, m in zip(time[start:], bulk[start:]) if t <= time[start] + RHO_WINDOW + 1e-9]
    rho_b = sum(rho_rows) / len(rho_rows)
    scale = rho_b * math.sqrt(g) * (orifice - K_FIXED * diameter) ** 2.5
    return {"D": orifice, "d": diameter, "W_measured": rate, "W_beverloo": C_BEVERLOO * scale,
            "C_fit": rate / scale, "rho_b": rho_b, "g": g, "t_start": time[start], "t_end": time[end],
            "points": end - start + 1}


COLUMNS = ["D", "d", "W_measured", "W_beverloo", "C_fit", "rho_b", "t_start", "t_end", "points"]


def write_rows(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(COLUMNS)
        for row in rows:
            writer.writerow([repr(row[c]) for c in COLUMNS])


def joint_fit(rows: list[dict]) -> tuple[float, float]:
    """C and k of Beverloo's law through every size: W^(2/5) = (C rho_b sqrt g)^(2/5) (D - k d)."""
    slope, intercept = line_fit([r["D"] for r in rows], [r["W_measured"] ** 0.4 for r in rows])
    rho_b = sum(r["rho_b"] for r in rows) / len(rows)
    d = sum(r["d"] for r in rows) / len(rows)
    g = rows[0]["g"]
    return slope ** 2.5 / (rho_b * math.sqrt(g)), -intercept / (slope * d)


def main() -> None:
    row = measure()
    earlier = []
    previous = Path("post/beverloo_rows.csv")
    if previous.is_file():
        with open(previous, newline="") as handle:
            earlier = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(handle)]
        for r in earlier:
            r["points"] = int(r["points"])
    rows = [r for r in earlier if abs(r["D"] - row["D"]) > 1e-9] + [row]
    rows.sort(key=lambda r: r["D"])
    for r in rows:
        r.setdefault("g", row["g"])
    Path("post").mkdir(exist_ok=True)
    write_rows(previous, rows)
    write_rows(Path("beverloo.csv"), rows)
    if len(rows) >= 3:
        c, k = joint_fit(rows)
        Path("beverloo_fit.txt").write_text(f"C k sizes\n{c!r} {k!r} {len(rows)}\n")
    print(f"D = {row['D'] * 1000:g} mm, d = {row['d'] * 1000:g} mm: W = {row['W_measured']:.5g} kg/s "
          f"(Beverloo C = 0.58, k = 1.5: {row['W_beverloo']:.5g} kg/s), rho_b = {row['rho_b']:.5g} kg/m^3, "
          f"C_fit = {row['C_fit']:.4g} over t = {row['t_start']:g} ... {row['t_end']:g} s")


if __name__ == "__main__":
    main()
