"""Restart files (.npz): everything needed to continue a scene bitwise, checked before use.

A restart holds the domain, walls, particles (in memory order, each field of state.PARTICLE_FIELDS under its
name), the neighbor list with its contact history, step and time. The compiled kernel does not check
bounds, so a file whose arrays disagree must be refused as bad input before it reaches it.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from . import clumps, superquadrics
from . import state as particle_state
from .errors import InputError, output_failure
from .mesh import MeshList
from .neighbor import from_half_list
from .script import Fields
from .walls import of_shape, valid as valid_wall

RESTART_FORMAT = 2
#: restart file arrays of the neighbor list (the particle fields are stored under their names, state.py)
NEIGHBOR_ARRAYS = {"nbr_start": "start", "nbr_j": "j", "pair_hist": "hist"}


def write_restart(sim, path: str):
    """Everything needed to continue bitwise: particles in memory order, neighbor list, contact history."""
    if sim.lo is None:
        raise InputError(f"restart {path}: nothing to write (no domain yet)")
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as handle:
            np.savez(handle, format=RESTART_FORMAT, step=sim.step, time=sim.time,
                     dt=np.nan if sim.dt is None else sim.dt, skin=sim.skin, lo=sim.lo, hi=sim.hi,
                     periodic=sim.periodic, next_id=sim.next_id, dirty=sim.dirty,
                     walls=json.dumps(sim.walls), **wall_arrays(sim),
                     modifier_state=json.dumps(modifier_state(sim)),
                     **particle_state.as_arrays(sim.state),
                     **{key: getattr(sim.nbr, name) for key, name in NEIGHBOR_ARRAYS.items()},
                     **clumps.restart_arrays(sim), **superquadrics.restart_arrays(sim))
    except OSError as exc:
        raise output_failure("restart file", path, exc) from None
    sim.log.info(f"wrote restart file {path} at step {sim.step}")


def wall_arrays(sim) -> dict:
    """What the walls carry between runs: plane points, mesh triangles (as placed), angles and shifts, the
    last wall forces and torques, and the mesh contact list with its history."""
    meshes = [w["name"] for w in of_shape(sim.walls, "mesh")]
    triangles = [sim.mesh_triangles[name] for name in meshes]
    return dict(plane_point=sim.plane_point, wall_force=sim.wall_force, wall_torque=sim.wall_torque,
                mesh_angle=sim.mesh_angle, mesh_shift=sim.mesh_shift, mesh_travel=sim.mesh_travel,
                mesh_counts=np.array([len(t) for t in triangles], dtype=np.int64),
                mesh_triangles=np.concatenate(triangles) if triangles else np.zeros((0, 3, 3)),
                **{f"mesh_{key}": getattr(sim.mesh_nbr, key) for key in ("start", "tri", "hist", "owner")})


def _restore_walls(sim, data: dict, walls: list):
    sim.walls = walls
    sim.plane_point = data["plane_point"].copy()
    sim.wall_force = data["wall_force"].copy()
    sim.wall_torque = data["wall_torque"].copy()
    sim.mesh_angle = data["mesh_angle"].copy()
    sim.mesh_shift = data["mesh_shift"].copy()
    sim.mesh_travel = data["mesh_travel"].copy()
    bounds = np.concatenate([[0], np.cumsum(data["mesh_counts"])])
    names = [w["name"] for w in of_shape(walls, "mesh")]
    sim.mesh_triangles = {name: data["mesh_triangles"][bounds[k]:bounds[k + 1]].copy() for k, name in enumerate(names)}
    sim.mesh_nbr = MeshList(data["mesh_start"].copy(), data["mesh_tri"].astype(np.int32),
                            data["mesh_hist"].copy(), np.zeros(len(data["mesh_tri"]), dtype=np.uint8),
                            data["mesh_owner"].copy())


def modifier_state(sim) -> dict:
    """Counters of the modifiers that keep some (insert, outlet), by name: a continuation goes on counting
    and inserts with the next insertion's seeds, as the long run does."""
    return {name: {"kind": mod.kind, **mod.state()} for name, mod in sim.modifiers.items() if mod.state()}


def read_restart(sim, path: str, fields: Fields):
    """Restore a restart file, after checking that it is one: a truncated, foreign or inconsistent file
    must be bad input, never a crash, and never arrays whose sizes disagree reaching the compiled kernel
    (which does not check bounds)."""
    try:
        data = _load_restart(path)
    except OSError as exc:
        raise fields.error("file", f"cannot read restart file {path}: {exc.strerror or exc}") from None
    except Exception as exc:  # noqa: BLE001 - whatever a broken archive raises, the file is the problem
        raise fields.error("file", f"{path} is not a readable restart file ({type(exc).__name__}: "
                           f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None
    if data.get("format") is None or data["format"].shape != () or data["format"].dtype.kind not in "iu":
        raise fields.error("file", f"{path} is not a restart file of this engine (no format number)")
    if int(data["format"]) != RESTART_FORMAT:
        raise fields.error("file", f"{path} has restart format {int(data['format'])}, expected {RESTART_FORMAT}")
    try:
        walls = _check_restart(data)
    except ValueError as exc:
        raise fields.error("file", f"{path} is not a consistent restart file: {exc}") from None
    try:
        states = _modifier_states(data)
        clumps.restore(sim, data)
        superquadrics.restore(sim, data)
    except ValueError as exc:
        raise fields.error("file", f"{path} is not a consistent restart file: {exc}") from None
    for w in walls:
        if w["type"] not in sim.materials:
            raise fields.error("file", f"wall '{w['name']}' in {path} uses material type {w['type']} "
                               "which this script does not define")
    for t in set((data["ptype"] + 1).tolist()):
        if t not in sim.materials:
            raise fields.error("file", f"{path} holds particles of material type {t} which this script "
                               "does not define")
    sim.step = int(data["step"])
    sim.time = float(data["time"])
    if not math.isnan(float(data["dt"])):
        sim.dt = float(data["dt"])
    sim.skin = float(data["skin"])
    sim.lo, sim.hi = data["lo"].copy(), data["hi"].copy()
    sim.periodic = data["periodic"].copy()
    sim.next_id = int(data["next_id"])
    _restore_walls(sim, data, walls)
    sim.state = particle_state.from_arrays(data)
    start, j, hist = (np.ascontiguousarray(data[key]) for key in NEIGHBOR_ARRAYS)
    sim.nbr = from_half_list(start, j.astype(np.int32), hist, sim.n, 3)
    sim.dirty = bool(data["dirty"])
    sim.modifier_state = states
    for name, mod in sim.modifiers.items():  # modifiers created before the restart was read
        if states.get(name, {}).get("kind") == mod.kind:
            mod.restore(states[name])
    sim.log.info(f"read restart file {path}: step {sim.step}, {sim.n} particles")


def _load_restart(path: str) -> dict:
    """All arrays of a restart file (.npz), read eagerly so that a truncated member fails here."""
    archive = np.load(path, allow_pickle=False)
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise ValueError("a single .npy array, not an .npz archive")
    with archive:
        return {key: archive[key] for key in archive.files}


#: restart arrays: name -> (dtype kind, shape with "n" for the particle count)
_RESTART_SHAPES = {
    "x": ("f", ("n", 3)), "v": ("f", ("n", 3)), "f": ("f", ("n", 3)), "omega": ("f", ("n", 3)),
    "torque": ("f", ("n", 3)), "x_build": ("f", ("n", 3)), "radius": ("f", ("n",)), "mass": ("f", ("n",)),
    "inv_mass": ("f", ("n",)), "inv_inertia": ("f", ("n",)), "ptype": ("i", ("n",)), "pid": ("i", ("n",)),
    "nbr_start": ("i", (None,)), "nbr_j": ("i", (None,)), "pair_hist": ("f", (None, None)),
    "wall_hist": ("f", (None, None, None)), "step": ("i", ()), "time": ("f", ()), "dt": ("f", ()),
    "skin": ("f", ()), "lo": ("f", (3,)), "hi": ("f", (3,)), "periodic": ("b", (3,)), "next_id": ("i", ()),
    "dirty": ("b", ()), "walls": ("U", ()), "plane_point": ("f", (None, 3)), "wall_force": ("f", (None, 3)),
    "wall_torque": ("f", (None, 3)), "mesh_angle": ("f", (None,)), "mesh_shift": ("f", (None, 3)),
    "mesh_travel": ("f", (1,)), "mesh_counts": ("i", (None,)), "mesh_triangles": ("f", (None, 3, 3)), "mesh_start": ("i", (None,)),
    "mesh_tri": ("i", (None,)), "mesh_hist": ("f", (None, None)), "mesh_owner": ("i", (None,)),
}


def _check_restart(data: dict) -> list[dict]:
    """ValueError naming the first inconsistency of a restart file's arrays; returns its walls."""
    missing = sorted(set(_RESTART_SHAPES) - set(data))
    if missing:
        raise ValueError(f"missing {', '.join(missing)}")
    n = data["pid"].shape[0] if data["pid"].ndim == 1 else -1
    for key, (kind, shape) in _RESTART_SHAPES.items():
        a = data[key]
        want = tuple(n if d == "n" else d for d in shape)
        if (a.dtype.kind != kind or a.ndim != len(want)
                or any(w is not None and w != s for w, s in zip(want, a.shape))):
            raise ValueError(f"array '{key}' has dtype {a.dtype} and shape {a.shape}, expected kind '{kind}' and "
                             f"shape {tuple('N' if d == 'n' else ('*' if d is None else d) for d in shape)}")
        if kind == "f" and key != "dt" and not np.all(np.isfinite(a)):  # dt is NaN when none was set
            raise ValueError(f"array '{key}' holds non-finite values")
    if data["wall_hist"].shape[0] not in (0, n) or (data["wall_hist"].shape[0] == 0 and data["wall_hist"].size):
        raise ValueError(f"array 'wall_hist' has {data['wall_hist'].shape[0]} rows for {n} particles")
    if data["wall_hist"].shape[0] != n:  # written without wall history: none, for every particle
        data["wall_hist"] = np.zeros((n, 0, 0))
    if np.any(data["radius"] <= 0) or np.any(data["mass"] <= 0) or np.any(data["ptype"] < 0):
        raise ValueError("a particle with radius, mass or type out of range")
    if int(data["step"]) < 0 or not np.all(data["hi"] > data["lo"]) or float(data["skin"]) <= 0:
        raise ValueError("step, domain or skin out of range")
    pid = data["pid"]
    if len(np.unique(pid)) != n or (n and (pid.min() < 1 or pid.max() >= int(data["next_id"]))):
        raise ValueError("particle ids are not unique or not below next_id")
    start, j = data["nbr_start"], data["nbr_j"]
    if (not 1 <= len(start) <= n + 1 or start[0] != 0 or np.any(np.diff(start) < 0) or start[-1] != len(j)
            or (len(j) and (j.min() < 0 or j.max() >= n))):
        raise ValueError("the neighbor list does not fit the particles")
    if data["pair_hist"].shape[0] != len(j) and data["pair_hist"].size:
        raise ValueError(f"{data['pair_hist'].shape[0]} contact history rows for {len(j)} listed pairs")
    try:
        walls = json.loads(str(data["walls"]))
    except ValueError as exc:
        raise ValueError(f"the wall list is not JSON ({exc})") from None
    if not isinstance(walls, list) or not all(valid_wall(w) for w in walls):
        raise ValueError("the wall list is not a list of wall definitions")
    planes = len(of_shape(walls, "plane"))
    if data["plane_point"].shape[0] != planes:
        raise ValueError(f"{data['plane_point'].shape[0]} plane points for {planes} planes")
    meshes = len(of_shape(walls, "mesh"))
    if not (len(data["mesh_counts"]) == len(data["mesh_angle"]) == len(data["mesh_shift"]) == meshes
            and int(data["mesh_counts"].sum()) == len(data["mesh_triangles"]) and np.all(data["mesh_counts"] > 0)):
        raise ValueError(f"the mesh arrays do not fit the {meshes} mesh walls")
    if len(data["wall_force"]) not in (0, len(walls)) or len(data["wall_torque"]) != len(data["wall_force"]):
        raise ValueError(f"wall forces and torques do not fit the {len(walls)} walls")
    ms, mt = data["mesh_start"], data["mesh_tri"]
    if (len(ms) != len(data["mesh_owner"]) + 1 or ms[0] != 0 or np.any(np.diff(ms) < 0) or ms[-1] != len(mt)
            or (len(mt) and (mt.min() < 0 or mt.max() >= len(data["mesh_triangles"])))
            or data["mesh_hist"].shape[0] != len(mt)):
        raise ValueError("the mesh contact list does not fit the meshes")
    return walls


def _modifier_states(data: dict) -> dict:
    """The modifier counters of a restart file (absent in files written before insert and outlet existed)."""
    if "modifier_state" not in data:
        return {}
    array = data["modifier_state"]
    if array.dtype.kind != "U" or array.shape != ():
        raise ValueError("array 'modifier_state' is not a text")
    try:
        states = json.loads(str(array))
    except ValueError as exc:
        raise ValueError(f"the modifier counters are not JSON ({exc})") from None
    if not (isinstance(states, dict) and all(isinstance(v, dict) and isinstance(v.get("kind"), str)
                                             for v in states.values())):
        raise ValueError("the modifier counters are not a map of modifier names to counters")
    for name, values in states.items():
        for key, value in values.items():
            if key != "kind" and (not isinstance(value, (int, float)) or (isinstance(value, float)
                                                                          and not math.isfinite(value))):
                raise ValueError(f"counter '{key}' of modifier '{name}' is not a finite number")
    return states
