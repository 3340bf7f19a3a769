"""Kernel builder: one compiled step loop per combination of named submodels.

A scene names its contact submodels (normal, tangential, cohesion, rolling), its kinds of walls (planes,
bounded planes, cylinders with a turning surface or an extent, meshes that stand, translate or rotate: the
fields of `engine.walls.features`), gravity and periodic axes: a `Combination`. The builder fills the templates below - the
neighbor loop, the wall loop and the step loop, each written once, after HOOMD-blue's
``PotentialPair<evaluator>`` - with exactly those pieces: the calls of the laws the scene names
(`engine.models.LAWS`), their parameter columns and history slots. The source goes into a cache folder, named
by a hash of its text, and is compiled with ``engine.jit.njit(cache=True)``: the machine code is keyed by the
content of each function and of the functions it calls, so a second run (another process, another build of
an engine whose kernels did not change) loads it from disk. What the scene does not name is not in the source: no
branch in the pair loop, no history array (pair history has width 0 without a history submodel), no wall pass
without walls, no mesh code without a mesh, no rotation code without a rotating mesh.

Templates are plain text with named slots: a line holding only ``${name}`` is replaced by the slot's lines,
indented as the slot is; ``${name}`` inside a line by its text (`render`).
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
from collections import namedtuple
from dataclasses import field, make_dataclass, replace

import numpy as np
from numba.core.dispatcher import Dispatcher

from . import cache_limit, clumps, superquadrics
from .contact_laws import slip_velocity
from .jit import cache_dir, content_key
from .models import LAWS, PARAMETERS, SUBMODELS, options
from .state import BLOCKS, FIELD_NAMES, interleaved
from .templates import render, unpack
from .walls import SHAPES, WALL_FEATURES, WALL_FIELDS, collect_wall_forces

#: scalars and small arrays every step reads: dt (s), characteristic velocity (m/s, Hooke), gravity (m/s^2, 3),
#: domain lo, hi (m, 3), periodic (3 booleans), skin (m). The fields of a namedtuple that compiled code
#: receives are part of its cache key (engine/jit.py).
Constants = namedtuple("Constants", ["dt", "characteristic_velocity", "gravity", "lo", "hi", "periodic", "skin",
                                     "history_transfer"])

class _CombinationLogic:
    """What the builder derives from a Combination (its fields: see `Combination`)."""

    def law(self, submodel: str):
        """The law named for a submodel, or None ('none')."""
        return LAWS.get((submodel, getattr(self, submodel)))

    def laws(self) -> list:
        """The named laws in evaluation order (models.SUBMODELS: normal -> cohesion -> tangential -> rolling)."""
        return [law for law in (self.law(kind) for kind in SUBMODELS) if law is not None]

    def parameter_columns(self) -> dict:
        """Parameter name -> column of the per type-pair table, for the parameters the named laws read."""
        used = {p for law in self.laws() for p in law.parameters}
        return {name: k for k, name in enumerate(p for p in PARAMETERS if p in used)}

    def history_offsets(self) -> dict:
        """Submodel -> first history column, for the laws that keep history (in evaluation order)."""
        offsets, width = {}, 0
        for law in self.laws():
            if law.history:
                offsets[law.submodel] = width
                width += law.history
        return offsets

    def history_transfer(self) -> tuple:
        """Per history column, the factor its value takes when the pair's i and j swap roles (Law.transfer)."""
        return tuple(law.transfer for law in self.laws() for _ in range(law.history))

    def reaction_columns(self) -> dict:
        """What a pair leaves for its partner j: the force (3 columns) and, per submodel that turns j, its torque
        contribution (3 columns) -> first column in the neighbor list's `reaction` rows. None on one thread
        (the pair adds to j directly)."""
        if not self.parallel:
            return {}
        columns = {"force": 0}
        for kind, sub in SUBMODELS.items():
            if sub.partner and self.law(kind) is not None:
                columns[kind] = 3 * len(columns)
        return columns

    @property
    def reaction_width(self) -> int:
        return 3 * len(self.reaction_columns())

    @property
    def has_walls(self) -> bool:
        return any(getattr(self, shape.features[0]) for shape in SHAPES.values())

    @property
    def history_width(self) -> int:
        """Doubles stored per contact (3 for the shear displacement, 3 for the EPSD2 rolling torque)."""
        return sum(law.history for law in self.laws())


#: Everything that changes the compiled code of a scene: a frozen dataclass with a field per kind of submodel
#: (the law's name, models.SUBMODELS) and per option of the contact model (models.options), a flag per wall
#: feature (walls.WALL_FEATURES), gravity, the periodic axes, clumps (multisphere bodies, engine/clumps.py) and
#: superquadrics (engine/superquadrics.py; both not in the repr, which the generated source quotes:
#: generate_source names them only where set) and parallel (loops compiled for several threads)
Combination = make_dataclass(
    "Combination",
    [(kind, str, field(default=sub.default)) for kind, sub in SUBMODELS.items()]
    + [(name, bool, field(default=option.default)) for name, option in options().items()]
    + [(name, bool, field(default=False)) for name in WALL_FEATURES]
    + [("gravity", bool, field(default=False)), ("periodic", tuple, field(default=(False, False, False))),
       ("clumps", bool, field(default=False, repr=False)), ("superquadrics", bool, field(default=False, repr=False)),
       ("parallel", bool, field(default=False))],
    bases=(_CombinationLogic,), frozen=True)


# ---------------------------------------------------------------- templates

#: force of one contact on i; the geometry (d, en*, vr*, vn, reff, meff, ...) is computed by the loop around it
CONTACT = """\
${before_force}
fx = fn * enx
fy = fn * eny
fz = fn * enz
${after_force}
fix += fx
fiy += fy
fiz += fz
${reaction}
"""

#: the lever is the contact radius r - d/2 (LIGGGHTS 3.8 surface_model_default.h; at walls too, confirmed by
#: the cross-code case wall_oblique); a wall does not spin
SLIP = {False: """\
cri = ri - 0.5 * d
crj = rj - 0.5 * d
wrx = cri * wix + crj * omega[j, 0]
wry = cri * wiy + crj * omega[j, 1]
wrz = cri * wiz + crj * omega[j, 2]
vtx, vty, vtz = slip_velocity(vrx, vry, vrz, vn, enx, eny, enz, wrx, wry, wrz)
""", True: """\
cri = ri - 0.5 * d
wrx = cri * wix
wry = cri * wiy
wrz = cri * wiz
vtx, vty, vtz = slip_velocity(vrx, vry, vrz, vn, enx, eny, enz, wrx, wry, wrz)
"""}

RELATIVE_SPIN = {False: "wrelx = wix - omega[j, 0]\nwrely = wiy - omega[j, 1]\nwrelz = wiz - omega[j, 2]\n",
                 True: "wrelx = wix\nwrely = wiy\nwrelz = wiz\n"}
#: what a law may need computed before its call (Law.needs), for pairs (False) and walls (True)
NEEDS = {"slip": SLIP, "relative_spin": RELATIVE_SPIN}
#: j takes the opposite force (Newton's third law). On several threads the pair leaves it in its row of
#: `reaction` and j adds it up in the particle pass; on one thread i subtracts it from f[j] at once - the same
#: operations on the same sums in the same order, so the same bytes. A wall takes it too (the force users can
#: print), collected at the last step of a chunk.
PAIR_REACTION = {True: "reaction[q, 0] = fx\nreaction[q, 1] = fy\nreaction[q, 2] = fz\n",
                 False: "f[j, 0] -= fx\nf[j, 1] -= fy\nf[j, 2] -= fz\n"}
#: and the torque about the origin of the force on the particle at the contact point c (the wall takes the
#: opposite). A plane or cylinder has one contact per particle; a mesh adds up its triangles' contacts.
WALL_REACTION = """\
${point}
if record:
    wall_part[i, w, 0] ${op} fx
    wall_part[i, w, 1] ${op} fy
    wall_part[i, w, 2] ${op} fz
    wall_tpart[i, w, 0] ${op} cy * fz - cz * fy
    wall_tpart[i, w, 1] ${op} cz * fx - cx * fz
    wall_tpart[i, w, 2] ${op} cx * fy - cy * fx
"""
#: the contact point of a plane or cylinder: the foot of the particle's centre on the surface
WALL_POINT = "cx = xi0 - enx * dist\ncy = xi1 - eny * dist\ncz = xi2 - enz * dist\n"

PARTICLE_HEAD = """\
xi0 = x[i, 0]
xi1 = x[i, 1]
xi2 = x[i, 2]
vix = v[i, 0]
viy = v[i, 1]
viz = v[i, 2]
wix = omega[i, 0]
wiy = omega[i, 1]
wiz = omega[i, 2]
ri = radius[i]
mi = mass[i]
ti = ptype[i]
fix = 0.0
fiy = 0.0
fiz = 0.0
tix = 0.0
tiy = 0.0
tiz = 0.0
"""

#: contact history is reset as soon as a contact opens (physically clean; see engine/README.md)
RESET_HISTORY = "for h in range(${width}):\n    ${target} = 0.0\n"

#: pass 1 of a force evaluation: each listed pair once, by its first particle i (i < j), i adding what j takes
#: straight to f[j] and torque[j] and its own sum to f[i] and torque[i] once its row ended (the serial loop).
#: On several threads each thread runs that serial loop over its share (shares: equal runs of whole blocks,
#: engine/neighbor.py share_start); a particle j whose pairs (q, j) all lie in its own share gets its sums
#: exactly as on one thread. Only the band (engine/neighbor.py boundary_band: j listed by some q of an earlier
#: share) is different: what j takes stays in the pair's row of `reaction`, marked by its byte in `touch` (a
#: pair not in contact writes only that byte, 0; pass 2 skips its row, which adding did not change: x - (+0.0)
#: and y + (+0.0) leave every sum bitwise as it is, since sums that start at +0.0 or m g never become -0.0),
#: and f[j] (set to +0.0 by start_band) gets only j's own sum; pass 2 adds gravity, the rows in increasing q
#: and the own sum, the serial order. No two threads write the same memory: a thread writes the forces of its
#: own share's particles and the rows of its own pairs.
#:
#: The pairs are taken a block of PAIR_BLOCK particles at a time (a thread's share is a run of blocks), and the
#: block's list entries CONTACT_CHUNK at a time, in three sweeps. (1) gather: the entries in contact, with what
#: their force reads (distance vector, radii, masses, relative velocity, spins, the type pair's parameters,
#: history) into the columns of `cin`; the others get their history reset. (2) contact: the force of every
#: gathered contact, a loop without loads from particle arrays, which LLVM turns into SIMD instructions (square
#: roots and divisions, which bound a contact's cost, 4 or 8 at a time; it does so only when the columns are a
#: constant distance apart: CONTACT_CHUNK is a literal); what each contact adds to i, j or its reaction row goes
#: to a column of `cout`. (3) sums: the contacts in list order add those columns exactly as the one-pass loop
#: added them (same operands, same order, the history written back; a particle's own sum once its row ended):
#: the bytes do not change (vector sqrt and division round as the scalar ones do, and nothing is contracted or
#: reassociated: benchmarks/engine_identical.py compares every run of testcases/).
PAIR_FORCES = '''\
@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def pair_forces(s, n, nbr, pp, dt, char_vel, box${bodies}):
    """Contact forces of the listed pairs (half list: each pair once, by i < j)."""
    ${unpack}
    ${same_body_head}
    nbr_start = nbr.start
    nbr_j = nbr.j
    pair_hist = nbr.hist
    rslot = nbr.rslot
    reaction = nbr.reaction
    pair_touch = nbr.touch
    ${band_head}
    pair_live = nbr.live
    nblocks = block_count(n, ${block})
    shares = ${shares}
    for t in prange(shares):
        cin = np.empty((${nin}, ${chunk}))
        cout = np.empty((${nout}, ${chunk}))
        ck = np.empty(${chunk}, dtype=np.int64)
        cj = np.empty(${chunk}, dtype=np.int64)
        ci = np.empty(${chunk}, dtype=np.int64)
        ${far_alloc}
        for blk in range(t * (nblocks // shares), (t + 1) * (nblocks // shares)):
            b = blk * n // nblocks
            e = (blk + 1) * n // nblocks
            gi = b
            row_end = nbr_start[b + 1]
            cur = b
            mine = False
            ${zero_sums}
            for c0 in range(nbr_start[b], nbr_start[e], ${chunk}):
                m = 0
                ${far_start}
                i = gi  # the sweep (2) before left other values in ri, mi, ...
                ${gather_head}
                ${body_i}
                for k in range(c0, min(c0 + ${chunk}, nbr_start[e])):
                    if k >= row_end:
                        gi += 1
                        while nbr_start[gi + 1] <= k:
                            gi += 1
                        row_end = nbr_start[gi + 1]
                        i = gi
                        ${gather_head}
                        ${body_i}
                    j = nbr_j[k]
                    dx = xi0 - x[j, 0]
                    dy = xi1 - x[j, 1]
                    dz = xi2 - x[j, 2]
                    ${periodic_image}
                    rsq = dx * dx + dy * dy + dz * dz
                    rj = radius[j]
                    radsum = ri + rj
                    ${same_body}
                    ck[m] = k
                    cj[m] = j
                    ci[m] = gi
                    cin[0, m] = dx
                    cin[1, m] = dy
                    cin[2, m] = dz
                    cin[3, m] = rsq
                    apart = rsq >= radsum * radsum
                    ${apart}
                    m += not apart
                ${far}
                for cq in range(m):
                    i = ci[cq]
                    j = cj[cq]
                    k = ck[cq]
                    ${gather}
                for cq in range(m):
                    ${load}
                    r = sqrt(rsq)
                    enx = dx / r
                    eny = dy / r
                    enz = dz / r
                    radsum = ri + rj
                    d = radsum - r
                    meff = mi * mj / (mi + mj)
                    reff = ri * rj / radsum
                    vn = vrx * enx + vry * eny + vrz * enz
                    ${contact}
                    ${store}
                for cq in range(m):
                    owner = ci[cq]
                    ${flush}
                    k = ck[cq]
                    j = cj[cq]
                    ${sums}
            ${flush_end}
'''
#: the listed pairs of a sweep found apart (cfar[:mf]): contact history reset - only where it is not zero
#: already (a test of its bits: a read, where a store would fetch and write back every pair's row), row not
#: touching (several threads, a partner in the band only: its reaction row is left as it is, pass 2 does not
#: read it; the rows of other partners are never read)
FAR = """\
for cq in range(mf):
    k = cfar[cq]
    ${reset_history}
    ${zero_row}
"""
#: a history row is +0.0 in every column exactly when its bits are all zero (-0.0 is reset too); a pair whose
#: live byte is 0 (apart at the last evaluation, or carried as +0.0 by the rebuild: engine/neighbor.py) has such a
#: row already, and its row is not read at all - in a loose packing most listed pairs are apart, and their
#: history rows were most of the bytes this sweep streamed
RESET_PAIR_HISTORY = """\
if pair_live[k]:
    pair_live[k] = 0
    if ${bits}:
        for h in range(${width}):
            pair_hist[k, h] = 0.0
"""
#: the end of particle cur's pairs (the next contact's owner, or the end of the block e): its own sum is added
#: only when it had a contact as i (mine) - adding +0.0 sums would change nothing but -0.0, and the particle pass
#: reads f + 0.0 (READ_SUMS). A band particle's force starts at +0.0 (engine/neighbor.py start_band): f holds its
#: own sum alone, added to gravity and the reaction rows by the particle pass (GATHER)
FLUSH = ("""\
if cur < owner:
    if mine:
        i = cur
        ${own_sum}
        ${zero_sums}
    cur = owner
mine = True
""", """\
if mine:
    i = cur
    ${own_sum}
""")
#: particles per block of the pair loop (a thread's unit of work; the results do not depend on it)
PAIR_BLOCK = 512
#: list entries per sweep of a block: the length of the columns (about 40 doubles per entry: 330 kB, in L2). Not a
#: multiple of 512: columns 4 kB apart share the same L1 cache sets (at 512 the pair pass took twice as long)
CONTACT_CHUNK = 1032
#: the columns of `cin` (gathered per contact): name -> what the gather stores; then one per parameter column
#: of the type pair (pp{c}) and per history double (h{h})
CONTACT_INPUTS = {"dx": None, "dy": None, "dz": None, "rsq": None, "ri": "radius[i]", "rj": "radius[j]",
                  "mi": "mass[i]", "mj": "mass[j]", "vrx": "v[i, 0] - v[j, 0]", "vry": "v[i, 1] - v[j, 1]",
                  "vrz": "v[i, 2] - v[j, 2]", "wix": "omega[i, 0]", "wiy": "omega[i, 1]", "wiz": "omega[i, 2]",
                  "wj0": "omega[j, 0]", "wj1": "omega[j, 1]", "wj2": "omega[j, 2]"}
#: a line of contact code that adds to a sum of i, of j or to j's reaction row (the only lines with effects
#: beyond the contact: models.py and CONTACT write them at the top level of a contact)
_SUM_LINE = re.compile(r"^(?P<target>tix|tiy|tiz|fix|fiy|fiz|f\[j, \d\]|torque\[j, \d\]|reaction\[q, \d+\])"
                       r" (?P<op>\+=|-=|=) (?P<expr>.+)$")


def split_contact(code: str, parameters: int, history: int) -> tuple:
    """The pair contact code (contact_code(c, "pair")) as the contact sweep's code and the sums sweep's code
    (see PAIR_FORCES): every line adding to a sum stores its operand in a column of `cout` instead, and the sums
    sweep adds that column in the same order; the type pair's parameters, j's spin and the history are read
    from the gathered locals. Returns (contact code, sums code, columns of cout)."""
    code = re.sub(r"pp\[ti, tj, (\d+)\]", r"pp\1", code)
    code = re.sub(r"omega\[j, (\d)\]", r"wj\1", code)
    code = re.sub(r"pair_hist\[k, (\d+)\]", r"h\1", code)
    contact, sums = [], []
    for line in code.splitlines():
        m = _SUM_LINE.match(line)
        if m is None:
            contact.append(line)
            continue
        column = len(sums)
        contact.append(f"cout[{column}, cq] = {m['expr']}")
        sums.append(f"{m['target']} {m['op']} cout[{column}, cq]")
    text = "\n".join(contact) + "\n"
    left = re.findall(r"\b(?:x|v|f|omega|torque|radius|mass|ptype|pair_hist|reaction|ti|tj|j|k|q)\b(?!\w)", text)
    if left or any(line.startswith((" ", "\t")) and _SUM_LINE.match(line.strip()) for line in code.splitlines()):
        raise ValueError(f"pair contact code reads particle arrays or sums inside a branch: {sorted(set(left))}")
    return text, "\n".join(sums) + "\n", len(sums)


#: a wall has infinite radius and mass (R* = r_i, m* = m_i); each shape's contacts (engine/walls/). The radius
#: and type of i are read only by a wall contact: with planes only, only where a plane is in reach (WALL_REACH)
WALLS = """\
${particle_head}
${wall_head}
reff = ri
meff = mi
${contacts}
ftot0 += fix
ftot1 += fiy
ftot2 += fiz
ttot0 += tix
ttot1 += tiy
ttot2 += tiz
"""

#: planes only: a particle none of whose planes is in reach since the last rebuild (plane bits zero,
#: engine/walls/plane.py PLANE_CONTACTS tests none) does not read its radius and type - 16 B per particle-step
#: of the arrays the particle pass streams; ri and ti are then never used
WALL_REACH = """\
if plane_near[i] != 0 or nplanes > PLANE_BITS:
    ri = radius[i]
    ti = ptype[i]
else:
    ri = 0.0
    ti = 0
"""

#: fix nve/sphere on particle i, whose total force and torque are ftot*, ttot* (read once): with kick, the
#: second half kick of v and omega (I = 0.4 m r^2); with drift, the next step's first half kick and the drift,
#: then the neighbor check (moved more than skin/2: rebuild; a non-finite position fails every comparison: the
#: run stops naming the particle). Without drift (a chunk's last step, setup) the totals are stored for Python
#: to read; with drift they are read for the last time here: on one thread the force and torque start the
#: next evaluation in the same pass (${clear}: gravity, zero; no separate pass to clear them), on several they
#: are not written at all (the pair pass assigns them; a clump member's are stored for its body). v, omega, x
#: are kept in locals between the kicks and the drift - the same operations in the same order as updating the
#: arrays in place, so the same bytes, without reloading what a store might have changed
INTEGRATE = """\
inv_mi = inv_mass[i]
inv_ii = inv_inertia[i]
${load}
if kick:
    ${half_kick}
if drift:
    ${half_kick}
    x0 = x[i, 0] + dt * v0
    x1 = x[i, 1] + dt * v1
    x2 = x[i, 2] + dt * v2
    x[i, 0] = x0
    x[i, 1] = x1
    x[i, 2] = x2
    ${clear}
    dx = x0 - x_build[i, 0]
    dy = x1 - x_build[i, 1]
    dz = x2 - x_build[i, 2]
    d2 = dx * dx + dy * dy + dz * dz
    if d2 > half_skin_sq:
        need += 1
    elif not d2 <= half_skin_sq:
        bad = min(bad, i)
else:
    ${store_totals}
v[i, 0] = v0
v[i, 1] = v1
v[i, 2] = v2
omega[i, 0] = w0
omega[i, 1] = w1
omega[i, 2] = w2
"""
#: v += dt/2 F/m, omega += dt/2 T/I (I = 0.4 m r^2, inv_inertia)
HALF_KICK = "".join(f"v{a} += half_dt * ftot{a} * inv_mi\nw{a} += half_dt * ttot{a} * inv_ii\n" for a in range(3))
STORE_TOTALS = ("f[i, 0] = ftot0\nf[i, 1] = ftot1\nf[i, 2] = ftot2\ntorque[i, 0] = ttot0\ntorque[i, 1] = ttot1\n"
                "torque[i, 2] = ttot2\n")
#: the totals Python stored (a chunk's first drift: drift_pass)
READ_TOTALS = ("ftot0 = f[i, 0]\nftot1 = f[i, 1]\nftot2 = f[i, 2]\nttot0 = torque[i, 0]\nttot1 = torque[i, 1]\n"
               "ttot2 = torque[i, 2]\n")
#: one thread, no gathering: the totals start from what the pair pass left in f and torque, + 0.0: the pair pass
#: adds a particle's own sum (never -0.0: it starts at +0.0) only when it had a contact as i, and x + 0.0 is x
#: but for -0.0 - exactly what adding a sum of +0.0 gave before (OWN_SUM, FLUSH)
READ_SUMS = "".join(f"{line} + 0.0\n" for line in READ_TOTALS.splitlines())

#: pass 2 of a force evaluation, per particle: its force and torque sums (READ_SUMS; on several threads a
#: particle of the band gathers them, GATHER); then walls, the second half kick and (but at a chunk's last step)
#: the next step's first half kick and drift. Returns (particles beyond skin/2, first non-finite position or n).
PARTICLE_PASS = '''\
@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def particle_pass(s, n, nbr, mnbr, walls, pp, dt, char_vel, gravity, kick, drift, record, wall_part, wall_tpart,
                  half_skin_sq, plane_near):
    """Forces from the pair rows, walls, integration; see the template in engine.kernels."""
    ${unpack}
    ${unpack_walls}
    mesh_start = mnbr.start
    mesh_tri = mnbr.tri
    mesh_hist = mnbr.hist
    mesh_touch = mnbr.touch
    rstart = nbr.rstart
    reaction = nbr.reaction
    pair_touch = nbr.touch
    band = nbr.band
    half_dt = 0.5 * dt
    need = 0
    bad = n
    for i in prange(n):
        ${gather}
        ${walls}
        ${integrate}
    return need, bad


@njit(cache=True, error_model="numpy", parallel=PARALLEL)
def drift_pass(s, n, dt, half_skin_sq, gravity):
    """The first half kick and drift of a chunk's first step. Returns (beyond skin/2, first bad or n)."""
    ${unpack}
    half_dt = 0.5 * dt
    need = 0
    bad = n
    kick = False
    drift = True
    for i in prange(n):
        ${read_totals}
        ${integrate}
    return need, bad
'''

#: several threads, a particle p of the band: gravity (F = m g, the first force), minus what the pairs (i, p) in
#: contact left for p, in increasing i, plus p's own pair sum (pass 1 added it to f[p] and torque[p], which
#: start_band set to +0.0: +0.0 when p had no contact as i, what adding the zero sum gave). A row whose pair
#: does not touch is not read (its line of memory not fetched): the pair pass does not write zeros there, and
#: subtracting +0.0 from a force or adding it to a torque sum (which starts at +0.0, so is never -0.0) left it
#: as it was
GATHER = """\
${clear}
gtx = 0.0
gty = 0.0
gtz = 0.0
for q in range(rstart[i], rstart[i + 1]):
    if pair_touch[q]:
        gfx -= reaction[q, 0]
        gfy -= reaction[q, 1]
        gfz -= reaction[q, 2]
        ${gather_torque}
ftot0 = gfx + f[i, 0]
ftot1 = gfy + f[i, 1]
ftot2 = gfz + f[i, 2]
ttot0 = gtx + torque[i, 0]
ttot1 = gty + torque[i, 1]
ttot2 = gtz + torque[i, 2]
"""
#: several threads: a band particle gathers (GATHER), any other reads its sums as on one thread
BAND_GATHER = """\
if band[i]:
    ${gather}
else:
    ${read_sums}
"""
#: the end of particle i's pairs: its own sum added to what the pairs (i', i), i' < i, already subtracted from f[i]
OWN_SUM = ("f[i, 0] += fix\nf[i, 1] += fiy\nf[i, 2] += fiz\ntorque[i, 0] += tix\ntorque[i, 1] += tiy\n"
           "torque[i, 2] += tiz\n")
#: forces start at gravity (F = m g) before the pairs add to them (several threads: the band at zero, see FLUSH)
CLEAR_FORCES = '''\
@njit(cache=True, error_model="numpy")
def clear_forces(s, n, gravity):
    ${blocks}
    f = s.f
    torque = s.torque
    mass = s.mass
    for i in range(n):
        ${clear}
        torque[i, 0] = 0.0
        torque[i, 1] = 0.0
        torque[i, 2] = 0.0
'''

#: the force the particles exert on each wall (engine/walls/__init__.py collect_wall_forces), only at steps where
#: Python reads it
WALL_FORCE_SUM = """\
if record:
    collect_wall_forces(walls.force, walls.torque, wall_part, wall_tpart)
"""

#: the start of a run after the scene changed, plain Python: it runs once per run, and compiled it would cost a
#: compilation of every pass it calls over again (Numba links the callees' code into the caller and optimizes
#: and compiles the whole), about a quarter of the compile time of a scene's kernels; from Python it calls the
#: passes' own compiled code, with the argument types run_steps gives them (one compilation each)
SETUP = '''\
def setup(s, n, nbr, mnbr, walls, pp, c, step, lost${bodies}${sq}):
    """Fresh neighbor lists and forces for the current state (start of a run after the scene changed).
    Returns (particles kept, neighbor list, mesh contact list)."""
    ${constants}
    box = hi - lo
    n, nbr = rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost, transfer)
    ${wall_setup}
    clear_forces(s, n, gravity)
    ${start_band}
    pair_forces(s, n, nbr, pp, dt, char_vel, box${bodies})
    record = True
    wall_part = np.zeros((n, ${nwalls}, 3))
    wall_tpart = np.zeros((n, ${nwalls}, 3))
    particle_pass(s, n, nbr, mnbr, walls, pp, dt, char_vel, gravity, False, False, record, wall_part, wall_tpart,
                  0.0, plane_near)
    ${body_setup}
    ${wall_force_sum}
    ${sq_setup}
    return n, nbr, mnbr
'''

#: the step loop, compiled. The passes' flags are run-time booleans (on, off) as Python passes them in setup: a
#: literal True or False is a type of its own to Numba, and the pass would be compiled once more for it
STEP_LOOP = '''\
@njit(cache=True, error_model="numpy")
def run_steps(s, n, nbr, mnbr, walls, pp, c, step0, nsteps, timers, lost${bodies}${sq}):
    """nsteps Velocity-Verlet steps (fix nve/sphere order) of the first n particles of state s. Returns
    (status, bad particle, steps done, rebuilds, particles kept, neighbor list, mesh contact list); status 1 =
    non-finite position. timers += [neigh, pair, modify] in s."""
    ${constants}
    box = hi - lo
    half_skin_sq = 0.25 * skin * skin
    on = np.bool_(True)
    off = np.bool_(False)
    status = 0
    bad = -1
    done = 0
    rebuilds = 0
    if nsteps == 0:
        return status, bad, done, rebuilds, n, nbr, mnbr
    t0 = now()
    ${wall_start}
    need, first_bad = drift_pass(s, n, dt, half_skin_sq, gravity)
    ${body_start}
    ${sq_start}
    neigh = 0.0
    pair = 0.0
    modify = now() - t0
    for k_step in range(nsteps):
        step = step0 + k_step + 1
        t0 = now()
        ${move_walls}
        if first_bad < n:
            status = 1
            bad = first_bad
            break
        t1 = now()
        ${wall_travel}
        if need > 0:
            n, nbr = rebuild(s, n, nbr, lo, hi, periodic, skin, step, lost, transfer)
            ${wall_rebuild}
            rebuilds += 1
        t2 = now()
        ${start_band}
        pair_forces(s, n, nbr, pp, dt, char_vel, box${bodies})
        t3 = now()
        record = k_step == nsteps - 1
        wall_part = np.zeros((n if record else 0, ${nwalls}, 3))
        wall_tpart = np.zeros((n if record else 0, ${nwalls}, 3))
        need, first_bad = particle_pass(s, n, nbr, mnbr, walls, pp, dt, char_vel, gravity, on, not record, record,
                                        wall_part, wall_tpart, half_skin_sq, plane_near)
        ${body_step}
        ${wall_force_sum}
        ${sq_step}
        t4 = now()
        neigh += t2 - t1
        pair += t3 - t2
        modify += (t1 - t0) + (t4 - t3)
        done += 1
    timers[0] += neigh
    timers[1] += pair
    timers[2] += modify
    return status, bad, done, rebuilds, n, nbr, mnbr
'''

CONSTANTS = """\
dt = c.dt
char_vel = c.characteristic_velocity
gravity = c.gravity
lo = c.lo
hi = c.hi
periodic = c.periodic
skin = c.skin
transfer = c.history_transfer
"""

MODULE = '''\
"""Generated by engine.kernels for ${combination}; do not edit."""
from math import sqrt

import numpy as np
from numba import prange

from engine.clock import now
from engine.jit import njit
from engine.neighbor import PARALLEL, block_count, rebuild, start_band
${imports}


${pair_forces}


${particle_pass}


${clear_forces}


${wall_functions}


${setup}


${step_loop}
'''


# ---------------------------------------------------------------- filling the slots

#: where a contact's history lives: pair k of the neighbor list, particle i's dense row of wall w, entry k of the
#: sparse mesh contact list
HISTORY = {"pair": "pair_hist[k, {h}]", "wall": "wall_hist[i, w, {h}]", "mesh": "mesh_hist[k, {h}]"}


def _law_call(c: Combination, law, place: str) -> str:
    """The law's call with its parameter columns and history slots filled in (place: pair, wall or mesh)."""
    columns = c.parameter_columns()
    offset = c.history_offsets().get(law.submodel, 0)
    names = {p: f"pp[ti, tj, {columns[p]}]" for p in law.parameters}
    names.update({f"h{k}": HISTORY[place].format(h=offset + k) for k in range(law.history)})
    return (law.pair if place == "pair" else law.wall_call).format(**names) + "\n"


def _submodel_code(c: Combination, kind: str, place: str) -> str:
    """A named submodel's code in a contact: its law's call inside its template (models.Submodel.applies), with
    what the law needs computed first, the options of its kind and (pairs only) what the partner takes."""
    sub, law = SUBMODELS[kind], c.law(kind)
    if law is None:
        return ""
    wall = place != "pair"
    partner = ""
    if sub.partner and not wall:
        o = c.reaction_columns().get(kind, 0)
        partner = render(sub.partner[c.parallel], o=str(o), o1=str(o + 1), o2=str(o + 2))
    options = {option.name: option.code.get(getattr(c, option.name), "") for option in sub.options}
    needs = "".join(NEEDS[need][wall] for need in law.needs)
    return render(sub.applies, law=_law_call(c, law, place), needs=needs, partner=partner, **options)


def contact_code(c: Combination, place: str) -> str:
    """The force of one pair (place "pair") or particle-wall contact (a plane or cylinder: "wall", a mesh
    triangle: "mesh"), for the named laws only."""
    if place == "pair":
        reaction = PAIR_REACTION[c.parallel]
    else:  # a mesh adds up the contacts of its triangles; its contact point comes from the triangle
        reaction = render(WALL_REACTION, op="+=" if place == "mesh" else "=",
                          point="" if place == "mesh" else WALL_POINT)
    before = "".join(_submodel_code(c, kind, place) for kind, sub in SUBMODELS.items() if sub.before_force)
    after = "".join(_submodel_code(c, kind, place) for kind, sub in SUBMODELS.items() if not sub.before_force)
    return render(CONTACT, before_force=before, after_force=after, reaction=reaction)


def _reset_history(c: Combination, place: str) -> str:
    if c.history_width == 0:
        return ""
    return render(RESET_HISTORY, width=str(c.history_width), target=HISTORY[place].format(h="h"))


def _gravity_force(c: Combination) -> tuple:
    if c.gravity:
        return "mass[i] * gravity[0]", "mass[i] * gravity[1]", "mass[i] * gravity[2]"
    return "0.0", "0.0", "0.0"


#: several threads, the partner's share of a contact: a particle of the band (engine/neighbor.py boundary_band)
#: takes it through the pair's reaction row, marked touching; any other particle straight into its force and
#: torque, as on one thread (its thread owns every pair that lists it)
BAND_SUMS = """\
${own}
if band[j]:
    q = rslot[k]
    pair_touch[q] = 1
    ${rows}
else:
    ${direct}
"""


def _band_sums(c: Combination, sums: str, parameters: int, width: int) -> str:
    """The sums sweep's code on several threads: i's own sums, then j's share by BAND_SUMS. sums is the sweep's
    code with reaction rows (the contact code of c); the direct lines come from the one-thread contact code,
    whose columns of cout are the same."""
    contact, _, _ = split_contact(contact_code(c, "pair"), parameters, width)
    serial_contact, serial_sums, _ = split_contact(contact_code(replace(c, parallel=False), "pair"), parameters,
                                                   width)
    if contact != serial_contact:
        raise ValueError("the one-thread and several-thread contact codes differ beyond the partner's share")
    def partner(line):
        return line.startswith(("f[j", "torque[j", "reaction[q"))
    own = [line for line in sums.splitlines() if line and not partner(line)]
    if own != [line for line in serial_sums.splitlines() if line and not partner(line)]:
        raise ValueError("the one-thread and several-thread own sums differ")
    return render(BAND_SUMS, own="\n".join(own), rows="\n".join(line for line in sums.splitlines() if partner(line)),
                  direct="\n".join(line for line in serial_sums.splitlines() if partner(line)))


def _pair_forces(c: Combination) -> str:
    periodic = "".join(f"d{name} -= box[{a}] * np.rint(d{name} / box[{a}])\n"
                       for a, name in enumerate("xyz") if c.periodic[a])
    rows = c.parallel  # several threads: pair rows for the partner, gathered in the particle pass
    # a pair apart marks its row not touching only where the particle the row is for is in the band: no other
    # row is read (GATHER), and every row of a band particle is written at every pass (1 in contact, 0 apart)
    zero_row = "if band[nbr_j[k]]:\n    pair_touch[rslot[k]] = 0" if rows else ""
    # clumps (engine/clumps.py): two members of one body do not touch; no such lines in a scene of spheres
    body_slots = dict(same_body_head=clumps.SAME_BODY_HEAD, body_i="body_i = member_body[pid[i]]",
                      same_body=render(clumps.SAME_BODY, zero_row=zero_row)) if c.clumps else \
        dict(same_body_head=None, body_i=None, same_body=None)
    nparam, width = len(c.parameter_columns()), c.history_width
    inputs = dict(CONTACT_INPUTS)
    inputs.update({f"pp{col}": f"pp[ti, tj, {col}]" for col in range(nparam)})
    inputs.update({f"h{h}": f"pair_hist[k, {h}]" for h in range(width)})
    gather = "".join(f"cin[{col}, cq] = {value}\n" for col, value in enumerate(inputs.values()) if value)
    gather = "ti = ptype[i]\ntj = ptype[j]\n" + gather if nparam else gather
    load = "".join(f"{name} = cin[{col}, cq]\n" for col, name in enumerate(inputs))
    first_hist = len(inputs) - width
    store = "".join(f"cin[{first_hist + h}, cq] = h{h}\n" for h in range(width))
    contact, sums, nout = split_contact(contact_code(c, "pair"), nparam, width)
    if rows:
        sums = _band_sums(c, sums, nparam, width)
    sums = "".join(f"pair_hist[k, {h}] = cin[{first_hist + h}, cq]\n" for h in range(width)) + sums
    if width:
        sums = "pair_live[k] = 1\n" + sums
    head = PARTICLE_HEAD[:PARTICLE_HEAD.index("fix = 0.0")]
    zero_sums = PARTICLE_HEAD[PARTICLE_HEAD.index("fix = 0.0"):]
    # the pairs found apart: their history reset and (several threads) their reaction rows zeroed, after the
    # contact-finding sweep; none of that without history on one thread
    reset = render(RESET_PAIR_HISTORY, width=str(width),
                   bits=" | ".join(f"hist_bits[k, {h}]" for h in range(width))) if width else ""
    far = dict(far_alloc=None, far_start=None, apart=None, far=None)
    if reset or zero_row:
        far = dict(far_alloc=f"cfar = np.empty({CONTACT_CHUNK}, dtype=np.int64)\nhist_bits = pair_hist.view(np.uint64)",
                   far_start="mf = 0",
                   apart="cfar[mf] = k\nmf += apart", far=render(FAR, reset_history=reset, zero_row=zero_row))
    return render(PAIR_FORCES, unpack=unpack("s", tuple(BLOCKS) + FIELD_NAMES), gather_head=head, block=str(PAIR_BLOCK), chunk=str(CONTACT_CHUNK),
                  zero_sums=zero_sums,
                  nin=str(len(inputs)), nout=str(max(nout, 1)), gather=gather, load=load, store=store, sums=sums,
                  periodic_image=periodic, contact=contact,
                  flush=render(FLUSH[0], own_sum=OWN_SUM, zero_sums=zero_sums),
                  flush_end=render(FLUSH[1], own_sum=OWN_SUM, zero_sums=zero_sums),
                  band_head="band = nbr.band" if rows else None,
                  shares="nbr.shares[0]" if rows else "1",
                  bodies=", bodies" if c.clumps else "", **far, **body_slots)


def _particle_pass(c: Combination, parts: list) -> str:
    """The particle pass: gathering the pair rows (several threads), the walls' contacts, integration."""
    walls = unpack_walls = ""
    if c.has_walls:
        contacts = "".join(part.contacts(lambda place: contact_code(c, place),
                                         lambda place: _reset_history(c, place)) for part in parts)
        wall_head = "ri = radius[i]\nti = ptype[i]\n"
        if all(not getattr(c, shape.features[0]) for name, shape in SHAPES.items() if name != "plane"):
            wall_head = WALL_REACH
        head = PARTICLE_HEAD.replace("ri = radius[i]\n", "").replace("ti = ptype[i]\n", "")
        walls = render(WALLS, particle_head=head, wall_head=wall_head, contacts=contacts)
        unpack_walls = unpack("walls", WALL_FIELDS[:-2]) + "nplanes = plane_point.shape[0]\n"
    gravity_force = _gravity_force(c)
    gather = ""
    if c.parallel:
        gather_torque = "".join(f"gtx += reaction[q, {o}]\ngty += reaction[q, {o + 1}]\ngtz += reaction[q, {o + 2}]\n"
                                for name, o in c.reaction_columns().items() if name != "force")
        gather = render(BAND_GATHER, read_sums=READ_SUMS, gather=render(
            GATHER, clear="".join(f"gf{a} = {g}\n" for a, g in zip("xyz", gravity_force)), gather_torque=gather_torque))
    # gravity, zero (several threads: the band's are set to zero before the pair pass, engine/neighbor.py
    # start_band)
    clear = "".join(f"f[i, {a}] = {g}\n" for a, g in enumerate(gravity_force)) + \
        "torque[i, 0] = 0.0\ntorque[i, 1] = 0.0\ntorque[i, 2] = 0.0\n"
    if c.clumps:  # a member's totals stay for its body's pass (engine/clumps.py)
        clear = clumps.member_clear(clear, STORE_TOTALS)
    load = "".join(f"{local}{a} = {array}[i, {a}]\n" for local, array in (("v", "v"), ("w", "omega")) for a in range(3))
    integrate = render(INTEGRATE, clear=clear, store_totals=STORE_TOTALS, half_kick=HALF_KICK, load=load)
    return render(PARTICLE_PASS, unpack=unpack("s", tuple(BLOCKS) + FIELD_NAMES), unpack_walls=unpack_walls,
                  gather=gather or READ_SUMS, walls=walls, integrate=integrate, read_totals=READ_TOTALS)


def _step_loop(c: Combination, parts: list, template: str) -> str:
    """The step loop (STEP_LOOP) or the setup (SETUP) of combination c."""
    def joined(hook):
        return "".join(getattr(part, hook) for part in parts)
    return render(template, constants=CONSTANTS, move_walls=joined("move"), wall_travel=joined("travel"),
                  wall_setup=joined("setup"), wall_start=joined("at_start"), wall_rebuild=joined("after_rebuild"),
                  nwalls="walls.force.shape[0]" if c.has_walls else "0",
                  start_band=f"start_band(nbr, n, {PAIR_BLOCK}, s.f, s.torque)" if c.parallel else None,
                  wall_force_sum=WALL_FORCE_SUM if c.has_walls else "",
                  # clumps (engine/clumps.py): the bodies' pass follows the particles'; none in a scene of spheres
                  bodies=", bodies" if c.clumps else "", body_setup=clumps.BODY_SETUP if c.clumps else None,
                  body_start=clumps.BODY_START if c.clumps else None, body_step=clumps.BODY_STEP if c.clumps else None,
                  # superquadrics (engine/superquadrics.py): their pass after the particles'; none in other scenes
                  sq=superquadrics.ARGUMENTS if c.superquadrics else "",
                  sq_setup=superquadrics.SETUP if c.superquadrics else None,
                  sq_start=superquadrics.START if c.superquadrics else None,
                  sq_step=superquadrics.STEP if c.superquadrics else None)


def generate_source(c: Combination) -> str:
    """Python source of the kernels for combination c, the particle fields by name (`laid_out` is what compiles)."""
    parts = [shape.kernel(c) for shape in SHAPES.values()]
    pair_forces, particle_pass = _pair_forces(c), _particle_pass(c, parts)
    setup, step_loop = _step_loop(c, parts, SETUP), _step_loop(c, parts, STEP_LOOP)
    clear_forces = render(CLEAR_FORCES, blocks=unpack("s", tuple(BLOCKS)), clear="".join(
        f"f[i, {a}] = {g}\n" for a, g in enumerate(_gravity_force(c))))
    body = pair_forces + particle_pass + setup + step_loop
    called = sorted({fn for law in c.laws() for fn in law.functions}, key=lambda fn: fn.__name__) + [slip_velocity]
    if c.has_walls:
        called.append(collect_wall_forces)
    called += [fn for part in parts for fn in part.calls]
    if c.clumps:
        called.append(clumps.body_pass)
    if c.superquadrics:
        called.append(superquadrics.superquadric_pass)
    imports = "".join(f"from {fn.__module__} import {fn.__name__}\n" for fn in called if fn.__name__ + "(" in body)
    # the clumps and superquadrics flags are named only where set: a scene of spheres has the source of an
    # engine without them
    named = "".join(f" with {flag}" for flag in ("clumps", "superquadrics") if getattr(c, flag))
    source = render(MODULE, combination=repr(c) + named, imports=imports, pair_forces=pair_forces,
                    particle_pass=particle_pass, clear_forces=clear_forces, setup=setup, step_loop=step_loop,
                    wall_functions="".join(part.functions for part in parts))
    # one thread: the loops compiled serially (prange is range there)
    return source if c.parallel else source.replace("parallel=PARALLEL", "parallel=False")


def parameter_table(c: Combination, materials: dict, interactions: dict, ntypes: int):
    """pp[ti, tj, column] for 0-based types ti, tj < ntypes (user types 1..ntypes; see seed 000 on
    off-by-one), with the columns of `Combination.parameter_columns` (the parameters the named laws read).

    Pairs without an interaction keep NaN in the columns that need one, so using one by mistake shows up as
    non-finite values.
    """

    columns = c.parameter_columns()
    pp = np.full((ntypes, ntypes, len(columns)), np.nan)
    for a in range(1, ntypes + 1):
        for b in range(1, ntypes + 1):
            if a not in materials or b not in materials:
                continue
            inter = interactions.get((min(a, b), max(a, b)))
            for name, k in columns.items():
                parameter = PARAMETERS[name]
                if inter is not None or not parameter.needs_interaction:
                    pp[a - 1, b - 1, k] = parameter.value(materials[a], materials[b], inter)
    return pp


# ---------------------------------------------------------------- building and caching

class _KernelModules:
    """Finds a generated kernel module by its name in the cache folder. Machine code is shared by the kernel
    modules whose functions are alike (engine/jit.py), and Numba, loading code another module compiled, imports
    that module for the globals the code was compiled with."""

    @staticmethod
    def find_spec(name, path=None, target=None):
        if re.fullmatch(r"dem_kernel_[0-9a-f]{20}", name) and (cache_dir() / f"{name}.py").exists():
            return importlib.util.spec_from_file_location(name, cache_dir() / f"{name}.py")
        return None


sys.meta_path.append(_KernelModules)

_loaded: dict = {}
#: the compiled functions of the kernel modules loaded in this process, by content key (engine/jit.py)
_functions: dict = {}


def laid_out(source: str) -> str:
    """Generated source as compiled: in each function that binds the state's blocks, the fields read and written
    by name (``x[j, 0]``, as `generate_source` writes them) indexed in their block (``xr[j, 0]``:
    engine/state.py interleaved)."""
    return "".join(interleaved(part) if all(f"{b} = s.{b}\n" in part for b in BLOCKS) else part
                   for part in re.split(r"(?=^@njit)", source, flags=re.M))


def build_kernel(c: Combination):
    """The compiled module (functions setup, run_steps) for combination c; generated and cached on disk."""
    if c in _loaded:
        return _loaded[c]
    source = laid_out(generate_source(c))
    # the file is named by its text; the machine code of each function in it is keyed by its content and the
    # functions it calls (engine/jit.py): a commit that leaves both alone compiles nothing
    key = hashlib.sha256(source.encode()).hexdigest()[:20]
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"dem_kernel_{key}.py"
    if not path.exists() or path.read_text() != source:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source)
        os.replace(tmp, path)  # atomic: parallel runs never import a half-written file
    else:
        cache_limit.touch(path)  # used now: the last to go when the cache is pruned (engine/cache_limit.py)
    name = f"dem_kernel_{key}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    # a function generated alike into a module loaded before (another combination in this process) is taken
    # from there: its machine code is compiled or loaded once per process
    for attr, value in list(vars(module).items()):
        if isinstance(value, Dispatcher) and value.py_func.__module__ == name:
            setattr(module, attr, _functions.setdefault(content_key(value), value))
    _loaded[c] = module
    return module
