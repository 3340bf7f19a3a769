"""Contact submodels as data: what the kernel builder and the commands need to know about each of them.

Two tables, after LAMMPS' granular submodels (`GranSubMod`: each declares its coefficients, its history size and
the sign its history takes when i and j swap roles):

- `SUBMODELS`: the kinds of submodel (normal, cohesion, tangential, rolling), in evaluation order (physics.md),
  each with the coefficients of `create interaction` it reads, the flags of `create contact_model` that change
  it (`Option`), and the kernel template that applies what its law leaves behind to the contact (force, torque
  on i, and the partner's share). A new kind (twisting, say) is one `Submodel` row plus its laws.
- `LAWS`: the choices of each kind - pure function (`engine.contact_laws`), the per type-pair parameters it reads
  (named columns of `PARAMETERS`), the doubles of history it keeps per contact and their transfer sign, what it
  needs computed before it (the slip velocity, the relative spin), and its call in the kernel's pair and wall
  loops. A new law is one `Law` row plus its function.

The builder (`engine.kernels`) compiles only the laws a scene names; the parameter table holds only the columns
they read.

A call is a line of Python with placeholders: ``{name}`` for a parameter of `PARAMETERS` (the builder puts the
table entry of the contact's type pair there) and ``{h0}``, ``{h1}`` ... for the law's history doubles. What
each submodel must leave behind (its slot contract, read by the submodels after it):

- normal: ``fn, kn, kt, gn, gt`` (N, N/m, N/m, kg/s, kg/s) from ``d, vn, reff, meff`` (and ``char_vel``);
- cohesion: adds its (attractive, <= 0) force to ``fn``; reads ``r, ri, rj`` (pairs) or ``dist, ri`` (walls);
- tangential: ``ftx, fty, ftz`` (N, on i) from the slip velocity ``vtx, vty, vtz``, ``kt, gt, fn, dt``;
- rolling: ``rtx, rty, rtz`` (N m; the torque on i is -rt, on j +rt) from ``wrelx, wrely, wrelz``.

Geometry every call may read: ``en*`` (unit normal j -> i), ``d`` (overlap, m), ``vn`` (m/s), ``reff`` (m),
``meff`` (kg), ``dt`` (s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import contact_laws as cl


@dataclass(frozen=True)
class Coefficient:
    """A field of `create interaction` a submodel reads (per pair of material types).

    default None: required. check(value) -> the problem of a value ('' when it is fine).
    """

    name: str
    default: float | None = 0.0
    minimum: float | None = 0.0
    check: object = None


@dataclass(frozen=True)
class Option:
    """A flag of `create contact_model` that changes a submodel's code: code[value] fills the slot of its name in
    the submodel's template (no entry: nothing)."""

    name: str
    default: bool
    code: dict


def _restitution_problem(e: float) -> str:
    return "" if 0.0 < e <= 1.0 else f"must be in (0, 1], got {e:g}"


#: the force of the tangential slot acts at the contact point: torque -cr (en x Ft) on both partners (physics.md)
TANGENTIAL = """\
${tangential_damping}
${needs}
${law}
fx += ftx
fy += fty
fz += ftz
tqx = -(eny * ftz - enz * fty)
tqy = -(enz * ftx - enx * ftz)
tqz = -(enx * fty - eny * ftx)
tix += cri * tqx
tiy += cri * tqy
tiz += cri * tqz
${partner}
"""
#: the rolling torque rt turns i by -rt and its partner by +rt
ROLLING = """\
${needs}
${law}
tix -= rtx
tiy -= rty
tiz -= rtz
${partner}
"""


@dataclass(frozen=True)
class Submodel:
    """A kind of contact submodel.

    default: the law when a script names none ('none': no code), required: a script must name it;
    coefficients: the `create interaction` fields its laws read; options: the `create contact_model` flags that
    change its code; applies: the template that applies its law's outputs (slots ``${law}``, ``${needs}`` - the
    quantities the law needs, ``${partner}`` and one per option); before_force: it changes ``fn`` before the
    normal force vector is formed; partner: {several threads: template} of what the partner j takes (as torque,
    into the pair's reaction row at columns ``${o}``, ``${o1}``, ``${o2}``; on one thread added to j at once).
    """

    kind: str
    default: str = "none"
    required: bool = False
    coefficients: tuple = ()
    options: tuple = ()
    applies: str = "${law}"
    before_force: bool = False
    partner: dict = field(default_factory=dict)


SUBMODELS = {sub.kind: sub for sub in (
    Submodel("normal", default="hertz", required=True, before_force=True,
             coefficients=(Coefficient("restitution", default=None, minimum=None, check=_restitution_problem),),
             options=(Option("limit_force", False, {True: "fn = max(fn, 0.0)"}),),
             applies="${law}\n${limit_force}\n"),
    Submodel("cohesion", before_force=True, coefficients=(Coefficient("cohesion_energy_density"),)),
    Submodel("tangential", coefficients=(Coefficient("friction"),),
             options=(Option("tangential_damping", True, {False: "gt = 0.0"}),), applies=TANGENTIAL,
             partner={True: "reaction[q, ${o}] = crj * tqx\nreaction[q, ${o1}] = crj * tqy\n"
                            "reaction[q, ${o2}] = crj * tqz\n",
                      False: "torque[j, 0] += crj * tqx\ntorque[j, 1] += crj * tqy\ntorque[j, 2] += crj * tqz\n"}),
    Submodel("rolling", coefficients=(Coefficient("rolling_friction"),), applies=ROLLING,
             partner={True: "reaction[q, ${o}] = rtx\nreaction[q, ${o1}] = rty\nreaction[q, ${o2}] = rtz\n",
                      False: "torque[j, 0] += rtx\ntorque[j, 1] += rty\ntorque[j, 2] += rtz\n"}),
)}


def options() -> dict:
    """Name -> Option of every submodel's options (flags of `create contact_model`)."""
    return {option.name: option for sub in SUBMODELS.values() for option in sub.options}


def coefficients() -> tuple:
    """The Coefficients of every submodel (fields of `create interaction`), in evaluation order."""
    return tuple(coefficient for sub in SUBMODELS.values() for coefficient in sub.coefficients)


@dataclass(frozen=True)
class Parameter:
    """A column of the per type-pair parameter table: value(material_i, material_j, interaction) -> float.

    Materials are (Young's modulus Pa, Poisson ratio, density kg/m^3); the interaction is the dict of
    `create interaction` (None when the pair has none: the entry stays NaN, so using it shows up as
    non-finite values).
    """

    unit: str
    doc: str
    value: object
    needs_interaction: bool = True


PARAMETERS = {
    "ystar": Parameter("Pa", "effective Young's modulus Y*",
                       lambda a, b, inter: cl.effective_youngs_modulus(a[0], a[1], b[0], b[1]), False),
    "gstar": Parameter("Pa", "effective shear modulus G*",
                       lambda a, b, inter: cl.effective_shear_modulus(a[0], a[1], b[0], b[1]), False),
    "beta": Parameter("-", "ln(e) / sqrt(ln(e)^2 + pi^2)", lambda a, b, inter: cl.restitution_beta(inter["restitution"])),
    "log_e": Parameter("-", "ln(e)", lambda a, b, inter: math.log(inter["restitution"])),
    "friction": Parameter("-", "Coulomb friction coefficient", lambda a, b, inter: inter["friction"]),
    "rolling_friction": Parameter("-", "rolling friction coefficient",
                                  lambda a, b, inter: inter["rolling_friction"]),
    "cohesion_energy_density": Parameter("J/m^3", "SJKR cohesion energy density",
                                         lambda a, b, inter: inter["cohesion_energy_density"]),
}


@dataclass(frozen=True)
class Law:
    """One submodel choice of a contact model (see the module docstring for the slot contracts)."""

    submodel: str
    name: str
    functions: tuple  # the pure laws its calls use
    pair: str
    wall: str = ""
    parameters: tuple = ()
    history: int = 0
    #: what the history becomes when i and j swap roles (the pair found the other way round at a rebuild):
    #: -1 for a vector antisymmetric in i and j (shear displacement, EPSD2 torque), +1 for a symmetric one
    transfer: float = -1.0
    needs: tuple = ()  # "slip" (slip velocity vt*), "relative_spin" (wrel*)
    source: str = ""

    @property
    def wall_call(self) -> str:
        return self.wall or self.pair


LAWS = {(law.submodel, law.name): law for law in (
    Law("normal", "hooke", (cl.hooke_normal,), parameters=("ystar", "log_e"),
        pair="fn, kn, kt, gn, gt = hooke_normal(d, vn, {ystar}, {log_e}, reff, meff, char_vel)",
        source="LIGGGHTS normal_model_hooke.h"),
    Law("normal", "hertz", (cl.hertz_normal,), parameters=("ystar", "gstar", "beta"),
        pair="fn, kn, kt, gn, gt = hertz_normal(d, vn, {ystar}, {gstar}, {beta}, reff, meff)",
        source="LIGGGHTS normal_model_hertz.h"),
    Law("cohesion", "sjkr", (cl.sjkr_pair_force, cl.sjkr_wall_force), parameters=("cohesion_energy_density",),
        pair="fn += sjkr_pair_force(r, ri, rj, {cohesion_energy_density})",
        wall="fn += sjkr_wall_force(dist, ri, {cohesion_energy_density})",
        source="LIGGGHTS cohesion_model_sjkr.h"),
    Law("tangential", "no_history", (cl.tangential_no_history,), parameters=("friction",), needs=("slip",),
        pair="ftx, fty, ftz = tangential_no_history(vtx, vty, vtz, gt, {friction}, fn)",
        source="LIGGGHTS tangential_model_no_history.h"),
    Law("tangential", "history", (cl.tangential_history,), parameters=("friction",), history=3, needs=("slip",),
        pair="ftx, fty, ftz, {h0}, {h1}, {h2} = tangential_history({h0}, {h1}, {h2}, vtx, vty, vtz, enx, eny, enz, "
             "kt, gt, {friction}, fn, dt)",
        source="LIGGGHTS tangential_model_history.h"),
    Law("rolling", "cdt", (cl.rolling_cdt,), parameters=("rolling_friction",), needs=("relative_spin",),
        pair="rtx, rty, rtz = rolling_cdt(wrelx, wrely, wrelz, enx, eny, enz, {rolling_friction}, kn * d, reff)",
        source="LIGGGHTS rolling_model_cdt.h"),
    Law("rolling", "epsd2", (cl.rolling_epsd2,), parameters=("rolling_friction",), history=3, needs=("relative_spin",),
        pair="rtx, rty, rtz = rolling_epsd2({h0}, {h1}, {h2}, wrelx, wrely, wrelz, enx, eny, enz, kt, reff, "
             "{rolling_friction}, fn, dt)\n{h0}, {h1}, {h2} = rtx, rty, rtz",
        source="LIGGGHTS rolling_model_epsd2.h"),
)}


def choices(submodel: str) -> tuple:
    """Names a script may give for a submodel ('none' for the optional ones)."""
    names = tuple(name for (kind, name) in LAWS if kind == submodel)
    return names if SUBMODELS[submodel].required else ("none",) + names
