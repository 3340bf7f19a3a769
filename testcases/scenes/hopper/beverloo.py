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

The same for both codes (issue 12's cross-code check): the run is the engine's when log.dem is in the folder,
LIGGGHTS' (in.liggghts) when log.liggghts is. For LIGGGHTS the same figures come from its log: D from the
region `orifice`, d from the particle templates and their mass fractions in particledistribution/discrete
(the number-mean diameter), g from fix gravity, the bulk region's volume, dt from `timestep`; the thermo
columns mall, msilo, mbulk (mass in the domain, the silo, the bulk region) give removed_mass = inserted mass -
mall (LIGGGHTS stops on a lost atom, so what is gone went through the outlet).
Both codes are read on the same grid, every GRID_STEPS = 500 steps (0.02 s; the engine's flow.csv has a row
every 250 steps, LIGGGHTS' thermo one every 100), so that the fits use the same instants.

discharge.csv (both codes, every 1000 steps from step 1000: the codes' common thermo steps) holds time,
atoms, removed_count, total = atoms + removed_count, lost, removed_mass, silo_mass, max_overlap (the largest
overlap over the smaller radius; LIGGGHTS: its thermo dmax, the largest pair overlap, over the smallest
template radius, a bound of the same): the series the run.config's
stability check (no particle lost but through the outlet) and the cross-code comparison read.

Rows accumulate along the chain of runs (depends_on copies post/ in): the row of this run joins the rows of
post/beverloo_rows.csv and that file, beverloo.csv and beverloo.txt (the same with blanks between words, for
the harness' word-by-word comparison of text files; columns D, d, W_measured, W_beverloo, C_fit,
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
GRID_STEPS = 500       # steps between the rows the fit uses (both codes)
DISCHARGE_STEPS = 1000  # steps between the rows of discharge.csv

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


def liggghts_log() -> tuple[list[str], list[tuple[list[str], list[list[float]]]]]:
    """Echoed commands (variables replaced: the last echo of a line wins) and thermo blocks of log.liggghts."""
    lines = Path("log.liggghts").read_text(errors="replace").splitlines()
    blocks, header = [], None
    for line in lines:
        tokens = line.split()
        if tokens[:1] == ["Step"]:
            header = tokens
            blocks.append((header, []))
        elif header and len(tokens) == len(header):
            try:
                blocks[-1][1].append([float(t) for t in tokens])
            except ValueError:
                pass
        elif line.startswith("Loop time"):
            header = None
    return lines, blocks


def liggghts_scene() -> dict:
    """D, d, g, the bulk region's volume, dt and the flow table (as flow.csv's columns) of a LIGGGHTS run."""
    lines, blocks = liggghts_log()
    commands = [l.split() for l in lines if l.strip() and not l.lstrip().startswith("#") and "${" not in l]
    regions = {c[1]: c for c in commands if c[0] == "region" and len(c) > 2}
    templates = {c[1]: float(c[c.index("radius") + 2]) for c in commands
                 if c[0] == "fix" and len(c) > 3 and c[3] == "particletemplate/sphere"}
    dist = next(c for c in commands if c[0] == "fix" and len(c) > 3 and c[3] == "particledistribution/discrete")
    pairs = [(templates[dist[6 + 2 * i]], float(dist[7 + 2 * i])) for i in range(int(dist[5]))]
    numbers = [fraction / r ** 3 for r, fraction in pairs]  # number fractions from mass fractions
    diameter = 2.0 * sum(n * r for n, (r, _) in zip(numbers, pairs)) / sum(numbers)
    gravity = next(c for c in commands if c[0] == "fix" and len(c) > 3 and c[3] == "gravity")
    dt = float(next(c for c in commands if c[0] == "timestep")[1])

    def cylinder(c):  # region ID cylinder z cx cy R lo hi
        return {"shape": "cylinder", "radius": float(c[6]), "z": [float(c[7]), float(c[8])]}

    rows = {}
    for header, table in blocks:
        for row in table:
            rows.setdefault(int(row[0]), dict(zip(header, row)))
    steps = sorted(s for s, r in rows.items() if r["Atoms"] > 0)
    inserted = max(rows[s]["mall"] for s in steps)
    flow = {"step": [float(s) for s in steps], "time": [s * dt for s in steps],
            "atoms": [rows[s]["Atoms"] for s in steps],
            "removed_mass[drain]": [inserted - rows[s]["mall"] for s in steps],
            "mass[region=silo]": [rows[s]["msilo"] for s in steps],
            "mass[region=bulk]": [rows[s]["mbulk"] for s in steps]}
    inserted_count = max(flow["atoms"])
    flow["removed_count[drain]"] = [inserted_count - a for a in flow["atoms"]]
    flow["lost"] = [0.0] * len(steps)
    smallest = min(r for r, _ in pairs)  # dmax / the smallest radius: a bound of overlap / smaller radius
    flow["max_overlap"] = [rows[s].get("dmax", math.nan) / smallest for s in steps]
    return {"D": 2.0 * cylinder(regions["orifice"])["radius"], "d": diameter, "g": float(gravity[4]),
            "bulk_volume": region_volume(cylinder(regions["bulk"])), "flow": flow}


def dem_scene() -> dict:
    """The same for an engine run: the commands echoed in log.dem, flow.csv and thermo.csv."""
    commands = scene_commands(Path("log.dem").read_text(encoding="utf-8", errors="replace"))
    regions = {c["name"]: c for c in commands if c.get("object") == "region"}
    packing = next(c for c in commands if c.get("object") == "random_packing")
    gravity = next(c for c in commands if c.get("kind") == "gravity")
    flow = read_flow("flow.csv")
    thermo = read_flow("thermo.csv")
    by_step = {int(s): i for i, s in enumerate(thermo["step"])}
    flow["atoms"] = [thermo["atoms"][by_step[int(s)]] if int(s) in by_step else math.nan for s in flow["step"]]
    for column in ("lost", "max_overlap"):
        flow[column] = [thermo[column][by_step[int(s)]] if int(s) in by_step else math.nan for s in flow["step"]]
    return {"D": 2.0 * regions["orifice"]["radius"], "d": packing["radius_min"] + packing["radius_max"],
            "g": math.sqrt(sum(a * a for a in gravity.get("acceleration", [0, 0, -9.81]))),
            "bulk_volume": region_volume(regions["bulk"]), "flow": flow}


def write_discharge(flow: dict) -> None:
    """discharge.csv: the rows both codes have (every DISCHARGE_STEPS steps from DISCHARGE_STEPS on)."""
    with open("discharge.csv", "w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(["time", "atoms", "removed_count", "total", "lost", "removed_mass", "silo_mass",
                         "max_overlap"])
        for i, step in enumerate(flow["step"]):
            if step >= DISCHARGE_STEPS and int(step) % DISCHARGE_STEPS == 0:
                atoms, removed = flow["atoms"][i], flow["removed_count[drain]"][i]
                writer.writerow([round(step * DT_GRID, 9), repr(atoms), repr(removed), repr(atoms + removed),
                                 repr(flow["lost"][i]), repr(flow["removed_mass[drain]"][i]),
                                 repr(flow["mass[region=silo]"][i]), repr(flow["max_overlap"][i])])


DT_GRID = 4e-5  # s per step for discharge.csv's time column (set from the run in measure())


def measure() -> dict:
    global DT_GRID
    scene = liggghts_scene() if Path("log.liggghts").is_file() else dem_scene()
    orifice, diameter, g, bulk_volume = scene["D"], scene["d"], scene["g"], scene["bulk_volume"]
    flow = scene["flow"]
    DT_GRID = flow["time"][-1] / flow["step"][-1]
    write_discharge(flow)
    keep = [i for i, s in enumerate(flow["step"]) if int(s) % GRID_STEPS == 0]
    time, removed, silo, bulk = ([flow[c][i] for i in keep] for c in
                                 ("time", "removed_mass[drain]", "mass[region=silo]", "mass[region=bulk]"))
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
    with open("beverloo.txt", "w") as out:  # the same rows, words separated by blanks (the cross-code check)
        out.write(" ".join(COLUMNS) + "\n")
        for r in rows:
            out.write(" ".join(f"{r[c]:.6g}" for c in COLUMNS) + "\n")
    if len(rows) >= 3:
        c, k = joint_fit(rows)
        Path("beverloo_fit.txt").write_text(f"C k sizes\n{c!r} {k!r} {len(rows)}\n")
    print(f"D = {row['D'] * 1000:g} mm, d = {row['d'] * 1000:g} mm: W = {row['W_measured']:.5g} kg/s "
          f"(Beverloo C = 0.58, k = 1.5: {row['W_beverloo']:.5g} kg/s), rho_b = {row['rho_b']:.5g} kg/m^3, "
          f"C_fit = {row['C_fit']:.4g} over t = {row['t_start']:g} ... {row['t_end']:g} s")


if __name__ == "__main__":
    main()
