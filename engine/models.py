"""Contact laws as data: what the kernel builder needs to know about each submodel a scene can name.

A law is its pure function (`engine.contact_laws`), the per type-pair parameters it reads (named columns of
the parameter table), how many doubles of history it keeps per contact, what it needs computed before it
(the slip velocity, the relative spin), and its call in the kernel's pair and wall loops. Adding a law is one
entry in `LAWS` plus its function; the builder (`engine.kernels`) compiles only the laws a scene names and
the parameter table holds only the columns they read.

A call is a line of Python with placeholders: ``{name}`` for a parameter of `PARAMETERS` (the builder puts the
table entry of the contact's type pair there) and ``{h0}``, ``{h1}`` ... for the law's history doubles. What
each submodel must leave behind (its slot contract, read by the submodels after it; physics.md gives the order
normal -> cohesion -> tangential -> rolling):

- normal: ``fn, kn, kt, gn, gt`` (N, N/m, N/m, kg/s, kg/s) from ``d, vn, reff, meff`` (and ``char_vel``);
- cohesion: adds its (attractive, <= 0) force to ``fn``; reads ``r, ri, rj`` (pairs) or ``dist, ri`` (walls);
- tangential: ``ftx, fty, ftz`` (N, on i) from the slip velocity ``vtx, vty, vtz``, ``kt, gt, fn, dt``;
- rolling: ``rtx, rty, rtz`` (N m; the torque on i is -rt, on j +rt) from ``wrelx, wrely, wrelz``.

Geometry every call may read: ``en*`` (unit normal j -> i), ``d`` (overlap, m), ``vn`` (m/s), ``reff`` (m),
``meff`` (kg), ``dt`` (s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import contact_laws as cl

SUBMODELS = ("normal", "cohesion", "tangential", "rolling")


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
    return names if submodel == "normal" else ("none",) + names
