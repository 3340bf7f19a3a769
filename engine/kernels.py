"""Kernel builder: one compiled step loop per combination of named submodels.

A scene names its contact submodels (normal, tangential, cohesion, rolling), whether it has plane or
cylinder walls, gravity and periodic axes. `build_kernel` writes Python source containing exactly those
pieces - calls into the pure laws of `engine.contact_laws` - into a cache folder keyed by a hash of the
engine's source and the combination, imports it and compiles it with ``@njit(cache=True)``, so a second run
(another process) loads the machine code from disk. What the scene does not name is not in the source: no
branch in the pair loop, no history array (pair history has width 0 without tangential history or EPSD2),
no wall pass without walls.

Parameter table ``pp[type_i, type_j, :]`` (types 0-based inside the engine, walls have types too):
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from dataclasses import dataclass
from pathlib import Path

from .state import FIELD_NAMES
from .walls import WALL_FIELDS

# columns of the per type-pair parameter table
P_YSTAR, P_GSTAR, P_BETA, P_LOG_E, P_FRICTION, P_ROLLING_FRICTION, P_COHESION = range(7)
N_PARAMS = 7
LAWS = ("hertz_normal", "hooke_normal", "sjkr_pair_force", "sjkr_wall_force", "slip_velocity",
        "tangential_history", "tangential_no_history", "rolling_cdt", "rolling_epsd2")

NORMAL_MODELS = ("hooke", "hertz")
TANGENTIAL_MODELS = ("none", "no_history", "history")
COHESION_MODELS = ("none", "sjkr")
ROLLING_MODELS = ("none", "cdt", "epsd2")


@dataclass(frozen=True)
class Combination:
    """Everything that changes the compiled code of a scene."""

    normal: str = "hertz"
    tangential: str = "history"
    cohesion: str = "none"
    rolling: str = "none"
    limit_force: bool = False
    tangential_damping: bool = True
    planes: bool = False
    cylinders: bool = False
    gravity: bool = False
    periodic: tuple = (False, False, False)

    @property
    def tangential_offset(self) -> int:
        return 0

    @property
    def rolling_offset(self) -> int:
        return 3 if self.tangential == "history" else 0

    @property
    def history_width(self) -> int:
        """Doubles stored per contact: 3 for the shear displacement, 3 for the EPSD2 rolling torque."""
        return (3 if self.tangential == "history" else 0) + (3 if self.rolling == "epsd2" else 0)


def _contact_block(c: Combination, wall: bool, indent: str) -> str:
    """Force law of one contact; expects d, r/dist, en*, vr*, vn, reff, meff, ri, ti, tj (and j for pairs)."""
    hist = (lambda h: f"wall_hist[i, w, {h}]") if wall else (lambda h: f"pair_hist[k, {h}]")
    lines = []
    if c.normal == "hertz":
        lines.append("fn, kn, kt, gn, gt = hertz_normal(d, vn, pp[ti, tj, 0], pp[ti, tj, 1], pp[ti, tj, 2], reff, meff)")
    else:
        lines.append("fn, kn, kt, gn, gt = hooke_normal(d, vn, pp[ti, tj, 0], pp[ti, tj, 3], reff, meff, char_vel)")
    if c.limit_force:
        lines.append("fn = max(fn, 0.0)")
    if c.cohesion == "sjkr":
        if wall:
            lines.append("fn += sjkr_wall_force(dist, ri, pp[ti, tj, 6])")
        else:
            lines.append("fn += sjkr_pair_force(r, ri, rj, pp[ti, tj, 6])")
    lines.append("fx = fn * enx")
    lines.append("fy = fn * eny")
    lines.append("fz = fn * enz")
    if c.tangential != "none":
        if not c.tangential_damping:
            lines.append("gt = 0.0")
        if wall:
            # the wall does not spin; the particle's lever is r - d/2 as for pairs (LIGGGHTS 3.8
            # surface_model_default.h; confirmed by the cross-code wall_oblique case against LIGGGHTS)
            lines += ["cri = ri - 0.5 * d", "wrx = cri * wix", "wry = cri * wiy", "wrz = cri * wiz"]
        else:
            lines += ["cri = ri - 0.5 * d", "crj = rj - 0.5 * d",
                      "wrx = cri * wix + crj * omega[j, 0]", "wry = cri * wiy + crj * omega[j, 1]",
                      "wrz = cri * wiz + crj * omega[j, 2]"]
        lines.append("vtx, vty, vtz = slip_velocity(vrx, vry, vrz, vn, enx, eny, enz, wrx, wry, wrz)")
        if c.tangential == "history":
            o = c.tangential_offset
            lines.append(f"ftx, fty, ftz, s0, s1, s2 = tangential_history({hist(o)}, {hist(o + 1)}, {hist(o + 2)}, "
                         "vtx, vty, vtz, enx, eny, enz, kt, gt, pp[ti, tj, 4], fn, dt)")
            lines += [f"{hist(o)} = s0", f"{hist(o + 1)} = s1", f"{hist(o + 2)} = s2"]
        else:
            lines.append("ftx, fty, ftz = tangential_no_history(vtx, vty, vtz, gt, pp[ti, tj, 4], fn)")
        lines += ["fx += ftx", "fy += fty", "fz += ftz",
                  # torque = -cr (en x Ft) on both partners (physics.md, tangential_model_history.h)
                  "tqx = -(eny * ftz - enz * fty)", "tqy = -(enz * ftx - enx * ftz)", "tqz = -(enx * fty - eny * ftx)",
                  "tix += cri * tqx", "tiy += cri * tqy", "tiz += cri * tqz"]
        if not wall:
            lines += ["torque[j, 0] += crj * tqx", "torque[j, 1] += crj * tqy", "torque[j, 2] += crj * tqz"]
    if c.rolling != "none":
        if wall:
            lines += ["wrelx = wix", "wrely = wiy", "wrelz = wiz"]
        else:
            lines += ["wrelx = wix - omega[j, 0]", "wrely = wiy - omega[j, 1]", "wrelz = wiz - omega[j, 2]"]
        if c.rolling == "cdt":
            lines.append("rtx, rty, rtz = rolling_cdt(wrelx, wrely, wrelz, enx, eny, enz, pp[ti, tj, 5], kn * d, reff)")
        else:
            o = c.rolling_offset
            lines.append(f"rtx, rty, rtz = rolling_epsd2({hist(o)}, {hist(o + 1)}, {hist(o + 2)}, wrelx, wrely, wrelz, "
                         "enx, eny, enz, kt, reff, pp[ti, tj, 5], fn, dt)")
            lines += [f"{hist(o)} = rtx", f"{hist(o + 1)} = rty", f"{hist(o + 2)} = rtz"]
        lines += ["tix -= rtx", "tiy -= rty", "tiz -= rtz"]
        if not wall:
            lines += ["torque[j, 0] += rtx", "torque[j, 1] += rty", "torque[j, 2] += rtz"]
    lines += ["fix += fx", "fiy += fy", "fiz += fz"]
    if wall:  # the wall takes the opposite force (a quantity users can print, e.g. the bottom load)
        lines += ["wall_force[w, 0] -= fx", "wall_force[w, 1] -= fy", "wall_force[w, 2] -= fz"]
    if not wall:
        lines += ["f[j, 0] -= fx", "f[j, 1] -= fy", "f[j, 2] -= fz"]
    return "".join(indent + ln + "\n" for ln in lines)


def _reset_history(c: Combination, wall: bool, indent: str) -> str:
    """Contact history is reset as soon as a contact opens (physically clean; see engine/README.md)."""
    if c.history_width == 0:
        return ""
    target = "wall_hist[i, w, h]" if wall else "pair_hist[k, h]"
    return (f"{indent}for h in range({c.history_width}):\n{indent}    {target} = 0.0\n")


def _unpack(obj: str, fields, names=None) -> str:
    """Fields of a state object as locals. Numba (0.68, issues 5872/7135) loses writes made through a
    namedtuple's attribute inside a parallel loop; locals are safe everywhere."""
    return "".join(f"    {name} = {obj}.{field}\n" for field, name in zip(fields, names or fields))


def _particle_head(indent: str) -> str:
    return "".join(indent + ln + "\n" for ln in [
        "xi0 = x[i, 0]", "xi1 = x[i, 1]", "xi2 = x[i, 2]",
        "vix = v[i, 0]", "viy = v[i, 1]", "viz = v[i, 2]",
        "wix = omega[i, 0]", "wiy = omega[i, 1]", "wiz = omega[i, 2]",
        "ri = radius[i]", "mi = mass[i]", "ti = ptype[i]",
        "fix = 0.0", "fiy = 0.0", "fiz = 0.0", "tix = 0.0", "tiy = 0.0", "tiz = 0.0"])


def _particle_tail(indent: str) -> str:
    return "".join(indent + ln + "\n" for ln in [
        "f[i, 0] += fix", "f[i, 1] += fiy", "f[i, 2] += fiz",
        "torque[i, 0] += tix", "torque[i, 1] += tiy", "torque[i, 2] += tiz"])


def generate_source(c: Combination) -> str:
    """Python source of the compiled kernels for combination c."""
    out = [f'"""Generated by engine.kernels for {c!r}; do not edit."""\n',
           "from math import sqrt\n", "import numpy as np\n", "from numba import njit\n",
           "from engine.clock import now\n", "from engine.neighbor import max_displacement_check, rebuild\n",
           "from engine.contact_laws import LAWS\n\n\n"]

    # ---- pair forces
    s = ["@njit(cache=True, error_model=\"numpy\")\n",
         "def pair_forces(s, n, nbr, pp, dt, char_vel, box):\n",
         _unpack("s", FIELD_NAMES), _unpack("nbr", ("start", "j", "hist"), ("nbr_start", "nbr_j", "pair_hist")),
         "    for i in range(n):\n", _particle_head(" " * 8),
         "        for k in range(nbr_start[i], nbr_start[i + 1]):\n",
         "            j = nbr_j[k]\n",
         "            dx = xi0 - x[j, 0]\n", "            dy = xi1 - x[j, 1]\n", "            dz = xi2 - x[j, 2]\n"]
    for a, name in enumerate("xyz"):
        if c.periodic[a]:
            s.append(f"            d{name} -= box[{a}] * np.rint(d{name} / box[{a}])\n")
    s += ["            rsq = dx * dx + dy * dy + dz * dz\n",
          "            rj = radius[j]\n", "            radsum = ri + rj\n",
          "            if rsq >= radsum * radsum:\n", _reset_history(c, False, " " * 16),
          "                continue\n",
          "            r = sqrt(rsq)\n", "            enx = dx / r\n", "            eny = dy / r\n",
          "            enz = dz / r\n", "            d = radsum - r\n",
          "            mj = mass[j]\n", "            tj = ptype[j]\n",
          "            meff = mi * mj / (mi + mj)\n", "            reff = ri * rj / radsum\n",
          "            vrx = vix - v[j, 0]\n", "            vry = viy - v[j, 1]\n", "            vrz = viz - v[j, 2]\n",
          "            vn = vrx * enx + vry * eny + vrz * enz\n",
          _contact_block(c, False, " " * 12), _particle_tail(" " * 8), "\n\n"]
    out += s

    # ---- wall forces
    if c.planes or c.cylinders:
        s = ["@njit(cache=True, error_model=\"numpy\")\n",
             "def wall_forces(s, n, walls, pp, dt, char_vel):\n",
             _unpack("s", FIELD_NAMES), _unpack("walls", WALL_FIELDS),
             "    wall_force = walls.force\n",
             "    nplanes = plane_axis.shape[0]\n",
             "    wall_force[:, :] = 0.0\n",
             "    for i in range(n):\n", _particle_head(" " * 8),
             "        reff = ri\n", "        meff = mi\n"]
        if c.planes:
            s += ["        for w in range(nplanes):\n",
                  "            axis = plane_axis[w]\n",
                  "            sep = x[i, axis] - plane_pos[w]\n",
                  "            dist = abs(sep)\n",
                  "            if dist >= ri:\n", _reset_history(c, True, " " * 16), "                continue\n",
                  "            sign = 1.0 if sep >= 0.0 else -1.0\n",
                  "            enx = sign if axis == 0 else 0.0\n",
                  "            eny = sign if axis == 1 else 0.0\n",
                  "            enz = sign if axis == 2 else 0.0\n",
                  "            d = ri - dist\n", "            tj = plane_type[w]\n",
                  "            vrx = vix - plane_vel[w, 0]\n", "            vry = viy - plane_vel[w, 1]\n",
                  "            vrz = viz - plane_vel[w, 2]\n",
                  "            vn = vrx * enx + vry * eny + vrz * enz\n",
                  _contact_block(c, True, " " * 12)]
        if c.cylinders:
            s += ["        for q in range(cyl_radius.shape[0]):\n",
                  "            w = nplanes + q\n",
                  "            px = xi0 - cyl_center[q, 0]\n", "            py = xi1 - cyl_center[q, 1]\n",
                  "            rho = sqrt(px * px + py * py)\n",
                  "            if cyl_side[q] > 0:\n",
                  "                dist = cyl_radius[q] - rho\n",
                  "            else:\n",
                  "                dist = rho - cyl_radius[q]\n",
                  "            if dist >= ri or rho == 0.0:\n", _reset_history(c, True, " " * 16),
                  "                continue\n",
                  # en points from the wall to the particle: inward for an inside wall, outward outside
                  "            enx = -cyl_side[q] * px / rho\n", "            eny = -cyl_side[q] * py / rho\n",
                  "            enz = 0.0\n",
                  "            d = ri - dist\n", "            tj = cyl_type[q]\n",
                  "            vrx = vix\n", "            vry = viy\n", "            vrz = viz\n",
                  "            vn = vrx * enx + vry * eny + vrz * enz\n",
                  _contact_block(c, True, " " * 12)]
        s += [_particle_tail(" " * 8), "\n\n"]
        out += s

    # ---- forces of one step: clear, gravity, pairs, walls
    clear = ("            f[i, 0] = mass[i] * gravity[0]\n            f[i, 1] = mass[i] * gravity[1]\n"
             "            f[i, 2] = mass[i] * gravity[2]\n") if c.gravity else \
        "            f[i, 0] = 0.0\n            f[i, 1] = 0.0\n            f[i, 2] = 0.0\n"
    walls = "        wall_forces(s, n, walls, pp, dt, char_vel)\n" if (c.planes or c.cylinders) else ""
    move_planes = ("        for w in range(walls.plane_axis.shape[0]):\n"
                   "            walls.plane_pos[w] += walls.plane_vel[w, walls.plane_axis[w]] * dt\n") if c.planes else ""
    args = "s, n, nbr, walls, pp, c, step0, nsteps, timers, lost"
    unpack_constants = ("    dt = c.dt\n    char_vel = c.characteristic_velocity\n    gravity = c.gravity\n"
                        "    lo = c.lo\n    hi = c.hi\n    periodic = c.periodic\n    skin = c.skin\n")
    rebuild_call = "n, nbr = rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost)\n"
    unpack_state = "".join(f"            {name} = s.{name}\n" for name in FIELD_NAMES)
    out += [
        "@njit(cache=True, error_model=\"numpy\")\n",
        "def setup(s, n, nbr, walls, pp, c, step, lost):\n",
        "    \"\"\"Fresh neighbor list and forces for the current state (start of a run after the scene changed).\n"
        "    Returns (particles kept, neighbor list).\"\"\"\n",
        unpack_constants,
        "    box = hi - lo\n",
        "    " + rebuild_call,
        unpack_state.replace("            ", "    "),
        "    for i in range(n):\n", clear.replace("\n        ", "\n    ")[4:],
        "        torque[i, 0] = 0.0\n        torque[i, 1] = 0.0\n        torque[i, 2] = 0.0\n",
        "    pair_forces(s, n, nbr, pp, dt, char_vel, box)\n",
        walls.replace("\n    ", "\n")[4:] if walls else "",
        "    return n, nbr\n\n\n",
        "@njit(cache=True, error_model=\"numpy\")\n",
        f"def run_steps({args}):\n",
        "    \"\"\"nsteps Velocity-Verlet steps (fix nve/sphere order) of the first n particles of state s. Returns\n"
        "    (status, bad particle, steps done, rebuilds, particles kept, neighbor list); status 1 = non-finite\n"
        "    position. timers += [neigh, pair, modify] in s.\"\"\"\n",
        unpack_constants,
        "    box = hi - lo\n",
        "    half_skin_sq = 0.25 * skin * skin\n",
        "    half_dt = 0.5 * dt\n",
        "    status = 0\n    bad = -1\n    done = 0\n    rebuilds = 0\n",
        "    for k_step in range(nsteps):\n",
        "        step = step0 + k_step + 1\n",
        "        t0 = now()\n",
        unpack_state.replace("            ", "        "),
        "        for i in range(n):\n",
        "            for a in range(3):\n",
        "                v[i, a] += half_dt * f[i, a] * inv_mass[i]\n",
        "                x[i, a] += dt * v[i, a]\n",
        "                omega[i, a] += half_dt * torque[i, a] * inv_inertia[i]\n",
        move_planes,
        "        t1 = now()\n",
        "        need, bad = max_displacement_check(x, x_build, half_skin_sq, n)\n",
        "        if bad >= 0:\n            status = 1\n            break\n",
        "        if need:\n",
        "            " + rebuild_call.replace("\n            ", "\n                "),
        "            rebuilds += 1\n",
        "        t2 = now()\n",
        unpack_state.replace("            ", "        "),
        "        for i in range(n):\n", clear,
        "            torque[i, 0] = 0.0\n            torque[i, 1] = 0.0\n            torque[i, 2] = 0.0\n",
        "        pair_forces(s, n, nbr, pp, dt, char_vel, box)\n",
        "        t3 = now()\n",
        walls,
        "        for i in range(n):\n",
        "            for a in range(3):\n",
        "                v[i, a] += half_dt * f[i, a] * inv_mass[i]\n",
        "                omega[i, a] += half_dt * torque[i, a] * inv_inertia[i]\n",
        "        t4 = now()\n",
        "        timers[0] += t2 - t1\n        timers[1] += t3 - t2\n        timers[2] += (t1 - t0) + (t4 - t3)\n",
        "        done += 1\n",
        "    return status, bad, done, rebuilds, n, nbr\n",
    ]
    text = "".join(out)
    # import exactly the laws the code calls, nothing else
    used = [law for law in LAWS if law + "(" in text]
    return text.replace("LAWS\n", ", ".join(used) + "\n", 1)


def _engine_source_hash() -> str:
    digest = hashlib.sha256()
    here = Path(__file__).parent
    for name in ("kernels.py", "contact_laws.py", "neighbor.py", "clock.py", "state.py", "walls.py"):
        digest.update((here / name).read_bytes())
    return digest.hexdigest()


def cache_dir() -> Path:
    """$DEM_CACHE_DIR, else ~/.cache/dem-engine."""
    env = os.environ.get("DEM_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "dem-engine"


_loaded: dict = {}


def build_kernel(c: Combination):
    """The compiled module (functions setup, run_steps) for combination c; generated and cached on disk."""
    if c in _loaded:
        return _loaded[c]
    source = generate_source(c)
    key = hashlib.sha256((_engine_source_hash() + repr(c)).encode()).hexdigest()[:20]
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"dem_kernel_{key}.py"
    if not path.exists() or path.read_text() != source:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)  # atomic: parallel runs never import a half-written file
    name = f"dem_kernel_{key}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _loaded[c] = module
    return module
