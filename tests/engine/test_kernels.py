"""The kernel builder: contact laws as data, templates with named slots, only the named effects compiled."""
import dataclasses
import math

import numpy as np

from engine import contact_laws as cl
from engine import kernels, models
from engine.kernels import Combination, generate_source, parameter_table, render


def test_render_indents_block_slots_and_fills_inline_ones():
    template = "def f(${arg}):\n    ${body}\n    return y\n"
    out = render(template, arg="x", body="y = x\nif y < 0:\n    y = -y")
    assert out == "def f(x):\n    y = x\n    if y < 0:\n        y = -y\n    return y\n"


def test_a_new_contact_law_is_one_entry(monkeypatch):
    """A law is its function, named parameter columns and a call; the builder does the rest."""
    law = models.Law("normal", "linear_test", (cl.hooke_normal,), parameters=("ystar", "friction"),
                     pair="fn, kn, kt, gn, gt = hooke_normal(d, vn, {ystar}, {friction}, reff, meff, char_vel)")
    monkeypatch.setitem(models.LAWS, ("normal", "linear_test"), law)
    c = Combination(normal="linear_test", tangential="none", planes=True)
    assert c.parameter_columns() == {"ystar": 0, "friction": 1}
    source = generate_source(c)
    assert source.count("hooke_normal(d, vn, pp[ti, tj, 0], pp[ti, tj, 1], reff, meff, char_vel)") == 2  # pair, wall
    assert "from engine.contact_laws import hooke_normal" in source
    compile(source, "kernel", "exec")
    materials = {1: (1e7, 0.3, 2500.0)}
    pp = parameter_table(c, materials, {(1, 1): dict(restitution=0.5, friction=0.4, rolling_friction=0.0,
                                                       cohesion_energy_density=0.0)}, 1)
    assert pp.shape == (1, 1, 2) and pp[0, 0, 1] == 0.4
    assert pp[0, 0, 0] == cl.effective_youngs_modulus(1e7, 0.3, 1e7, 0.3)


def test_history_and_reaction_columns_follow_the_named_laws():
    full = Combination(normal="hertz", tangential="history", cohesion="sjkr", rolling="epsd2", parallel=True)
    assert full.history_offsets() == {"tangential": 0, "rolling": 3} and full.history_width == 6
    assert full.reaction_columns() == {"force": 0, "tangential": 3, "rolling": 6} and full.reaction_width == 9
    assert list(full.parameter_columns()) == ["ystar", "gstar", "beta", "friction", "rolling_friction",
                                              "cohesion_energy_density"]
    rolling_only = Combination(normal="hooke", tangential="none", rolling="epsd2", parallel=True)
    assert rolling_only.history_offsets() == {"rolling": 0} and rolling_only.reaction_columns() == {
        "force": 0, "rolling": 3}
    assert "pair_hist[k, 0], pair_hist[k, 1], pair_hist[k, 2] = rtx, rty, rtz" in generate_source(rolling_only)
    bare = Combination(normal="hertz", tangential="none", parallel=True)
    assert bare.history_width == 0 and bare.reaction_width == 3 and list(bare.parameter_columns()) == [
        "ystar", "gstar", "beta"]
    assert dataclasses.replace(full, parallel=False).reaction_width == 0  # one thread: no pair rows


def test_parameter_table_leaves_pairs_without_interaction_nan():
    c = Combination(normal="hertz", tangential="history")
    materials = {1: (1e7, 0.3, 2500.0), 2: (2e7, 0.25, 2500.0)}
    pp = parameter_table(c, materials, {(1, 1): dict(restitution=0.5, friction=0.3, rolling_friction=0.0,
                                                       cohesion_energy_density=0.0)}, 2)
    columns = c.parameter_columns()
    assert pp[0, 0, columns["beta"]] == cl.restitution_beta(0.5)
    assert math.isnan(pp[0, 1, columns["friction"]]) and not math.isnan(pp[0, 1, columns["ystar"]])
    assert np.array_equal(pp[0, 1], pp[1, 0], equal_nan=True)


def test_the_generated_loops_are_parallel_and_thread_safe_by_construction():
    """On several threads only the two force passes, the drift and (with planes) the plane bits are parallel
    loops and no loop body writes another particle's force (the partner's share goes to its pair row)."""
    combination = Combination(normal="hertz", tangential="history", rolling="cdt", planes=True, parallel=True)
    source = generate_source(combination)
    assert source.count("in prange(") == 4 and source.count("parallel=PARALLEL") == 4
    without_planes = generate_source(dataclasses.replace(combination, planes=False))
    assert without_planes.count("in prange(") == 3 and "def plane_reach" not in without_planes
    # one thread: the former serial loop, the partner's force added at once (the same sums in the same order)
    serial = generate_source(dataclasses.replace(combination, parallel=False))
    assert "parallel=PARALLEL" not in serial and "f[j, 0] -= fx" in serial and "reaction[q" not in serial
    assert "f[j" not in source and "torque[j" not in source
    assert "reaction[q, 3] = crj * tqx" in source and "reaction[q, 6] = rtx" in source
    assert kernels.Constants._fields == ("dt", "characteristic_velocity", "gravity", "lo", "hi", "periodic", "skin",
                                        "history_transfer")
