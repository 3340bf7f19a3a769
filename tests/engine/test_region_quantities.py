"""Regions and quantities per type and per region (issue 12).

`create region` names a box or z-cylinder that `region` fields (lattice, random_packing, insert, outlet) and
the quantities count|mass|ke|rke[type=T,region=R] name. Values are checked against numpy sums over the
particles the selection picks (centre inside, boundary included); a quantity naming a region that does not
exist is one ERROR line before the run.
"""
import math

import numpy as np
import pytest

from conftest import domain, interaction, material, model, particle, read_csv, run, timestep

TWO_TYPES = [domain(), material(1, rho=2500.0), material(2, rho=1000.0), interaction((1, 1)), interaction((1, 2)),
             interaction((2, 2)), model("hertz", "history"),
             {"command": "create", "object": "region", "name": "left", "shape": "box", "lo": [-1, -1, -1],
              "hi": [0, 1, 1]},
             {"command": "create", "object": "region", "name": "tube", "shape": "cylinder", "center": [0.5, 0],
              "radius": 0.1, "z": [-0.5, 0.5]}]
#: (type, radius, position, velocity, omega)
PARTICLES = [(1, 0.01, (-0.5, 0, 0), (1, 0, 0), (0, 0, 0)),
             (2, 0.01, (0.5, 0, 0), (0, 2, 0), (0, 1, 0)),
             (2, 0.02, (-0.5, 0.5, 0), (0, 0, 0), (0, 0, 3)),
             (1, 0.015, (0.55, 0.05, 0.2), (0, 0, -1), (2, 0, 0)),
             (2, 0.01, (0.0, 0.3, 0.0), (0.5, 0, 0), (0, 0, 0))]  # on the boundary x = 0 of 'left': inside


def _expected(quantity, ptype=None, region=None):
    t = np.array([p[0] for p in PARTICLES])
    r = np.array([p[1] for p in PARTICLES])
    x = np.array([p[2] for p in PARTICLES], float)
    v = np.array([p[3] for p in PARTICLES], float)
    w = np.array([p[4] for p in PARTICLES], float)
    rho = np.where(t == 1, 2500.0, 1000.0)
    m = rho * 4.0 / 3.0 * math.pi * r ** 3
    mask = np.ones(len(t), bool)
    if ptype is not None:
        mask &= t == ptype
    if region == "left":
        mask &= np.all((x >= [-1, -1, -1]) & (x <= [0, 1, 1]), axis=1)
    elif region == "tube":
        mask &= (np.hypot(x[:, 0] - 0.5, x[:, 1]) <= 0.1) & (np.abs(x[:, 2]) <= 0.5)
    return {"count": mask.sum(), "mass": m[mask].sum(), "ke": (0.5 * m * (v ** 2).sum(1))[mask].sum(),
            "rke": (0.5 * 0.4 * m * r ** 2 * (w ** 2).sum(1))[mask].sum()}[quantity]


SELECTIONS = [(q, t, reg) for q in ("count", "mass", "ke", "rke") for t in (None, 1, 2) for reg in (None, "left", "tube")
              if (t, reg) != (None, None)]


def _name(q, t, reg):
    parts = ([f"type={t}"] if t else []) + ([f"region={reg}"] if reg else [])
    return f"{q}[{','.join(parts)}]"


def test_selections_sum_the_particles_they_pick(engine_run):
    scene = TWO_TYPES + [particle(p[2], radius=p[1], velocity=p[3], omega=p[4], t=p[0]) for p in PARTICLES]
    scene += [{"command": "get", "property": _name(*s)} for s in SELECTIONS]
    scene += [{"command": "get", "property": "ke[ region=left , type=2 ]"}, {"command": "get", "property": "lost"}]
    code, folder = engine_run(scene)
    assert code == 0
    log = (folder / "log.dem").read_text()
    values = dict(line.split(" = ") for line in log.splitlines() if " = " in line and not line.startswith("command"))
    for s in SELECTIONS:
        got = float(values[_name(*s)])
        assert got == pytest.approx(_expected(*s), rel=1e-12, abs=0), s
    assert float(values["ke[ region=left , type=2 ]"]) == pytest.approx(_expected("ke", 2, "left"), rel=1e-12)
    assert values["lost"] == "0"
    # a selection of everything is the global quantity, to the byte
    assert _expected("count", None, None) == 5


def test_selections_as_thermo_columns_and_print_quantities(engine_run):
    scene = TWO_TYPES + [particle(p[2], radius=p[1], velocity=p[3], omega=p[4], t=p[0]) for p in PARTICLES]
    scene += [timestep(1e-5),
              {"command": "set", "property": "thermo", "every": 10,
               "columns": ["count[type=1]", "ke[type=2,region=left]", "lost"]},
              {"command": "create", "object": "modifier", "name": "p", "kind": "print", "every": 5,
               "file": "p.csv", "quantities": ["mass[region=tube]", "rke[type=1,region=tube]"]},
              {"command": "fix", "name": "p"}, run(20)]
    code, folder = engine_run(scene)
    assert code == 0
    header = (folder / "thermo.csv").read_text().splitlines()[0]
    assert header == 'step,time,atoms,ke,rke,count[type=1],"ke[type=2,region=left]",lost'  # quoted: a comma
    thermo = read_csv(folder / "thermo.csv")
    assert list(thermo["count[type=1]"]) == [2, 2, 2] and list(thermo["lost"]) == [0, 0, 0]
    assert thermo["ke[type=2,region=left]"][0] == pytest.approx(_expected("ke", 2, "left"), rel=1e-12)
    p = read_csv(folder / "p.csv")
    assert len(p["step"]) == 5 and p["mass[region=tube]"][0] == pytest.approx(_expected("mass", None, "tube"))


@pytest.mark.parametrize("command, message", [
    ({"command": "set", "property": "thermo", "columns": ["ke[region=bin]"]},
     "command 14 (run): field 'steps' cannot run: quantity 'ke[region=bin]' names no region 'bin' "
     "(regions: left, tube; create region first)"),
    ({"command": "set", "property": "thermo", "columns": ["inserted_count[feed]"]},
     "quantity 'inserted_count[feed]' names no insert modifier 'feed' (insert modifiers: none)"),
    ({"command": "set", "property": "thermo", "columns": ["removed_mass[p]"]},
     "quantity 'removed_mass[p]' names no outlet modifier 'p'"),
])
def test_unknown_regions_and_modifiers_are_refused_before_the_run(engine_run, command, message):
    scene = TWO_TYPES + [particle((0, 0, 0)), timestep(1e-5), command,
                         {"command": "create", "object": "modifier", "name": "p", "kind": "print", "every": 5,
                          "file": "p.csv", "quantities": ["step"]}, run(10)]
    code, folder = engine_run(scene)
    assert code == 2
    last = (folder / "log.dem").read_text().splitlines()[-1]
    assert last.startswith("ERROR: scene.json: command 14 (run): field 'steps' cannot run: ") and message in last
    assert not (folder / "thermo.csv").exists()


@pytest.mark.parametrize("name", ["ke[type=0]", "ke[colour=red]", "ke[type=1,type=2]", "ke[]", "count[region=]",
                                  "speed[type=1]"])
def test_malformed_selections_are_unknown_quantities(engine_run, name):
    code, folder = engine_run(TWO_TYPES + [{"command": "get", "property": name}])
    assert code == 2
    assert (folder / "log.dem").read_text().splitlines()[-1].endswith(f"names unknown property '{name}'")


def test_get_of_an_unknown_region_names_the_command(engine_run):
    code, folder = engine_run(TWO_TYPES + [{"command": "get", "property": "count[region=bin]"}])
    assert code == 2
    assert (folder / "log.dem").read_text().splitlines()[-1] == (
        "ERROR: scene.json: command 10 (get count[region=bin]): field 'property' quantity 'count[region=bin]' "
        "names no region 'bin' (regions: left, tube; create region first)")


def test_region_fields_take_names_and_objects(engine_run):
    scene = TWO_TYPES + [
        {"command": "create", "object": "lattice", "type": 1, "radius": 0.01, "spacing": 0.025, "region": "tube"},
        {"command": "create", "object": "random_packing", "type": 2, "count": 20, "seed": 3, "radius": 0.01,
         "region": "left"},
        {"command": "get", "property": "count[type=1,region=tube]"},
        {"command": "get", "property": "count[type=2,region=left]"}, {"command": "get", "property": "atoms"}]
    code, folder = engine_run(scene)
    assert code == 0
    log = (folder / "log.dem").read_text()
    assert "count[type=2,region=left] = 20" in log
    n_tube = int(log.split("count[type=1,region=tube] = ")[1].split()[0])
    assert n_tube > 50 and f"atoms = {n_tube + 20}" in log


@pytest.mark.parametrize("region, message", [
    ("nowhere", "field 'region' names no region 'nowhere' (regions: left, tube;"),
    (5, "field 'region' must be a region name or a region object"),
    ({"shape": "box", "lo": [0, 0, 0], "hi": [0, 1, 1]}, "region: field 'hi' must be greater than 'lo'"),
    ({"shape": "sphere"}, "region: field 'shape' must be one of box, cylinder"),
])
def test_bad_region_fields(engine_run, region, message):
    code, folder = engine_run(TWO_TYPES + [{"command": "create", "object": "lattice", "type": 1, "radius": 0.01,
                                            "spacing": 0.025, "region": region}])
    assert code == 2
    last = (folder / "log.dem").read_text().splitlines()[-1]
    assert last.startswith("ERROR: scene.json: command 10 (create lattice)") and message in last


def test_create_region_errors(engine_run):
    again = {"command": "create", "object": "region", "name": "left", "shape": "box", "lo": [0, 0, 0], "hi": [1, 1, 1]}
    code, folder = engine_run(TWO_TYPES + [again])
    assert code == 2
    assert "command 10 (create region): field 'name' 'left' is already a region" in (folder / "log.dem").read_text()
    bad = {"command": "create", "object": "region", "name": "c", "shape": "cylinder", "center": [0, 0],
           "radius": 1, "z": [1, 0]}
    code, folder = engine_run(TWO_TYPES + [bad], sub="b")
    assert code == 2
    assert "field 'z' must be [z_low, z_high]" in (folder / "log.dem").read_text()
