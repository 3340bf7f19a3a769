"""The kernel builder: contact laws as data, templates with named slots, only the named effects compiled."""
import dataclasses
import math
import re

import numpy as np
# at module level: inside a test, "conftest" is whichever folder's conftest the session imported last
from conftest import REPO

from engine import contact_laws as cl
from engine import kernels, models
from engine.kernels import Combination, generate_source, parameter_table, render


def test_render_indents_block_slots_and_fills_inline_ones():
    template = "def f(${arg}):\n    ${body}\n    return y\n"
    out = render(template, arg="x", body="y = x\nif y < 0:\n    y = -y")
    assert out == "def f(x):\n    y = x\n    if y < 0:\n        y = -y\n    return y\n"


def test_render_leaves_out_a_line_slot_given_none():
    """An optional hook (the clumps' slots) given None: the text of the template without that line; given an
    empty string the line stays empty (the slots of the other features)."""
    template = "def f(x):\n    ${hook}\n    ${empty}\n    return x\n${last}"
    assert render(template, hook=None, empty="", last=None) == "def f(x):\n\n    return x\n"
    assert render(template, hook="x += 1", empty="", last="y = f(0)") == \
        "def f(x):\n    x += 1\n\n    return x\ny = f(0)"


def test_a_new_contact_law_is_one_entry(monkeypatch):
    """A law is its function, named parameter columns and a call; the builder does the rest."""
    law = models.Law("normal", "linear_test", (cl.hooke_normal,), parameters=("ystar", "friction"),
                     pair="fn, kn, kt, gn, gt = hooke_normal(d, vn, {ystar}, {friction}, reff, meff, char_vel)")
    monkeypatch.setitem(models.LAWS, ("normal", "linear_test"), law)
    c = Combination(normal="linear_test", tangential="none", planes=True)
    assert c.parameter_columns() == {"ystar": 0, "friction": 1}
    source = generate_source(c)
    # the wall reads the type pair's table; the pair loop the columns its gather sweep copied (kernels.PAIR_FORCES)
    assert source.count("hooke_normal(d, vn, pp[ti, tj, 0], pp[ti, tj, 1], reff, meff, char_vel)") == 1
    assert source.count("hooke_normal(d, vn, pp0, pp1, reff, meff, char_vel)") == 1
    assert "cin[17, cq] = pp[ti, tj, 0]" in source and "cin[18, cq] = pp[ti, tj, 1]" in source
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
    rolling_source = generate_source(rolling_only)
    # the contact sweep updates the gathered history, the sums sweep writes it back (kernels.PAIR_FORCES)
    assert "h0, h1, h2 = rtx, rty, rtz" in rolling_source and "pair_hist[k, 2] = cin[" in rolling_source
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
    loops, and the pair pass writes another particle's force only where that particle is not in the boundary
    band (all its pairs are in the same thread's share); a band particle's share goes to its pair row."""
    combination = Combination(normal="hertz", tangential="history", rolling="cdt", planes=True, parallel=True)
    source = generate_source(combination)
    assert source.count("in prange(") == 4 and source.count("parallel=PARALLEL") == 4
    without_planes = generate_source(dataclasses.replace(combination, planes=False))
    assert without_planes.count("in prange(") == 3 and "def plane_reach" not in without_planes
    # one thread: the former serial loop, the partner's force added at once (the same sums in the same order)
    serial = generate_source(dataclasses.replace(combination, parallel=False))
    assert "parallel=PARALLEL" not in serial and "reaction[q" not in serial
    mine, partner = re.findall(r"cout\[(\d+), cq\] = fx\n", serial)  # what i adds, what j takes
    assert f"fix += cout[{mine}, cq]" in serial and f"f[j, 0] -= cout[{partner}, cq]" in serial
    # the partner's share: the pair row for a band particle, else straight into its force, as on one thread
    # (each branch: the lines indented deeper than its `if`, so the match cannot run into later code)
    band = re.search(r"\n( +)if band\[j\]:\n((?:\1 +\S[^\n]*\n)+)\1else:\n((?:\1 +\S[^\n]*\n)+)", source)
    assert band and "f[j" not in band[2] and "reaction[q, 0] = cout[" in band[2]
    assert f"f[j, 0] -= cout[{partner}, cq]" in band[3] and "reaction[q" not in band[3]
    assert source.count("f[j, 0] -=") == 1 and source.count("torque[j, 0] +=") == 2
    assert re.search(r"cout\[(\d+), cq\] = crj \* tqx", source) and "reaction[q, 3] = cout[" in source
    assert "reaction[q, 6] = cout[" in source
    assert kernels.Constants._fields == ("dt", "characteristic_velocity", "gravity", "lo", "hi", "periodic", "skin",
                                        "history_transfer")


def test_on_several_threads_forces_start_as_on_one_thread_but_the_band_at_zero():
    """The drift starts the next evaluation (gravity, zero) on any number of threads (a clump member stores its
    totals for its body instead); on several threads the step loop sets the band's forces to zero just before
    the pair pass (engine/neighbor.py start_band), and the particle pass gathers only the band's pair rows.
    That the values stay the same is tests/engine/test_parallel.py (1, 2 and 3 threads, bytes)."""
    combination = Combination(normal="hertz", tangential="history", planes=True, gravity=True, parallel=True)

    def integration(source):  # the particle pass's and the drift pass's integration (INTEGRATE)
        return re.findall(r"\n( +)if drift:\n(.*?)\n\1else:\n(.*?)\n\1v\[i, 0\] = v0", source, re.DOTALL)

    for parallel in (True, False):
        passes = integration(generate_source(dataclasses.replace(combination, parallel=parallel)))
        assert len(passes) == 2
        for _, drift, last in passes:
            assert "f[i, 2] = mass[i] * gravity[2]" in drift and "torque[i, 0] = 0.0" in drift
            assert "f[i, 0] = ftot0" in last and "torque[i, 2] = ttot2" in last
    for _, drift, _ in integration(generate_source(dataclasses.replace(combination, clumps=True))):
        assert re.search(r"if inv_mass\[i\] != 0\.0:\n +f\[i, 0\] = mass", drift)
        assert re.search(r"else:\n +f\[i, 0\] = ftot0", drift)
    source = generate_source(combination)
    step_loop = source[source.index("def run_steps"):]
    assert re.search(r"start_band\(nbr, n, \d+, s\.f, s\.torque\)\n +pair_forces\(", step_loop)
    assert re.search(r"if band\[i\]:\n +gfx = mass\[i\] \* gravity\[0\]", source)
    assert "start_band(" not in generate_source(dataclasses.replace(combination, parallel=False))


def test_a_new_kind_of_submodel_is_one_row_plus_its_law(tmp_path):
    """A twisting submodel (a torque about the normal, its partner turned the other way, one double of history
    that keeps its sign when i and j swap) added as one Submodel row and one Law row: the contact model command,
    the Combination, the history and reaction columns and the generated code follow."""
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent('''
        from engine import models, contact_laws as cl
        models.SUBMODELS["twisting"] = models.Submodel(
            "twisting", coefficients=(models.Coefficient("twisting_friction"),),
            applies="${needs}\\n${law}\\ntix -= mtx\\ntiy -= mty\\ntiz -= mtz\\n${partner}\\n",
            partner={True: "reaction[q, ${o}] = mtx\\nreaction[q, ${o1}] = mty\\nreaction[q, ${o2}] = mtz\\n",
                     False: "torque[j, 0] += mtx\\ntorque[j, 1] += mty\\ntorque[j, 2] += mtz\\n"})
        models.PARAMETERS["twisting_friction"] = models.Parameter(
            "-", "twisting friction", lambda a, b, inter: inter["twisting_friction"])
        models.LAWS[("twisting", "test")] = models.Law(
            "twisting", "test", (cl.rolling_cdt,), parameters=("twisting_friction",), history=1, transfer=1.0,
            needs=("relative_spin",),
            pair="mtx, mty, mtz = rolling_cdt(wrelx, wrely, wrelz, enx, eny, enz, {twisting_friction}, {h0}, reff)")
        from engine import commands, kernels, simulation
        from engine.script import Fields
        c = kernels.Combination(normal="hertz", tangential="history", twisting="test", parallel=True,
                                    planes=True)
        assert c.history_offsets() == {"tangential": 0, "twisting": 3}, c.history_offsets()
        assert c.history_transfer() == (-1.0, -1.0, -1.0, 1.0)
        assert c.reaction_columns() == {"force": 0, "tangential": 3, "twisting": 6}
        source = kernels.generate_source(c)
        assert "] = mtx" in source and "reaction[q, 6] = cout[" in source
        assert source.count("rolling_cdt(wrelx") == 2  # pair and walls
        assert "pp4, h3, reff)" in source and "pp[ti, tj, 4], wall_hist[i, w, 3], reff)" in source
        compile(source, "kernel", "exec")
        sim = simulation.Simulation.__new__(simulation.Simulation)
        sim.materials = {1: (1e7, 0.3, 2500.0)}
        sim.interactions = {}
        commands.create_interaction(sim, Fields({"types": [1, 1], "restitution": 0.5, "twisting_friction": 0.2},
                                                "test"))
        assert sim.interactions[(1, 1)]["twisting_friction"] == 0.2
        commands.create_contact_model(sim, Fields({"normal": "hertz", "twisting": "test"}, "test"))
        assert sim.model["twisting"] == "test" and sim.model["rolling"] == "none"
        print("ok")
    ''')
    out = subprocess.run([sys.executable, "-c", script], cwd=REPO, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin"},
                         capture_output=True, text=True)
    assert out.stdout.strip() == "ok", out.stderr


def test_the_pair_pass_resets_exactly_the_pairs_apart():
    """The contact-finding sweep keeps the pairs in contact and the pairs apart without a branch (kernels.PAIR_FORCES):
    every pair apart - and only those - gets its history reset (to +0.0, also from -0.0) and, on several threads,
    its row marked as not touching (`touch`, in the rows' order), its reaction row left unwritten. On several
    threads only the pairs whose partner is in the boundary band write their reaction row and its mark, at every
    pass (whatever a mark held before: the particle pass reads the band's rows only); every other partner takes
    its share in its force at once and its row's mark is not written."""
    import numba

    from engine import state as particle_state
    from engine.neighbor import empty_list, lost_record, rebuild, start_band

    rng = np.random.default_rng(3)
    n = 2000  # several blocks of the pair pass and several column lengths of list entries
    lo, hi = np.zeros(3), np.array([0.1, 0.1, 0.1])
    x = lo + rng.random((n, 3)) * (hi - lo)
    radius = np.full(n, 0.003)
    mass = 2500.0 * 4.0 / 3.0 * np.pi * radius ** 3
    materials = {1: (1e7, 0.3, 2500.0)}
    inter = {(1, 1): {"restitution": 0.5, "friction": 0.3, "rolling_friction": 0.0, "cohesion_energy_density": 0.0}}
    for parallel in (False, True):
        c = Combination(normal="hertz", tangential="history", parallel=parallel)
        module = kernels.build_kernel(c)
        s = particle_state.append(particle_state.empty(0, 3), x=x.copy(), radius=radius, mass=mass,
                                  inv_mass=1.0 / mass, inv_inertia=1.0 / (0.4 * mass * radius ** 2),
                                  pid=np.arange(1, n + 1), v=0.01 * rng.standard_normal((n, 3)),
                                  x_build=x.copy(), omega=np.ones((n, 3)))
        nbr = empty_list(3, c.reaction_width)
        kept, nbr = rebuild(s, n, nbr, lo, hi, np.zeros(3, dtype=np.bool_), 0.002, 1, lost_record(n), -np.ones(3))
        assert kept == n
        nbr.hist[:] = 1e-6
        nbr.hist[::3] = -0.0  # rows whose bits are not zero though they compare equal to zero
        nbr.hist[1::3, 1] = 0.0
        nbr.live[:] = 1  # histories written here: every row may be nonzero (engine/neighbor.py NeighborList)
        nbr.reaction[:] = 7.0
        nbr.touch[:] = 1  # stale marks (an earlier pass, another band)
        pp = parameter_table(c, materials, inter, 1)
        if parallel:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
            start_band(nbr, n, kernels.PAIR_BLOCK, s.f, s.torque)
        module.pair_forces(s, n, nbr, pp, 1e-5, 1.0, hi - lo)
        owner = np.repeat(np.arange(n), np.diff(nbr.start))
        d = np.linalg.norm(s.x[owner] - s.x[nbr.j], axis=1)
        apart = d >= radius[owner] + radius[nbr.j]
        assert 0 < apart.sum() < len(apart) and (~apart).sum() > 1032  # both kinds, more contacts than a column
        assert np.all(nbr.hist[apart].view(np.uint64) == 0) and np.all(nbr.hist[~apart] != 1e-6)
        in_band = np.zeros(len(nbr.j), dtype=bool)
        assert np.all(nbr.live[apart] == 0) and np.all(nbr.live[~apart] == 1)
        if parallel:  # pair k's row is rslot[k]; the rows of pairs apart are marked, not written
            in_band = nbr.band[nbr.j] == 1
            assert (numba.config.NUMBA_NUM_THREADS == 1) == (not in_band.any())
            rows, touch = nbr.reaction[nbr.rslot], nbr.touch[nbr.rslot]
            assert np.all(touch[apart & in_band] == 0) and np.all(touch[~apart & in_band] == 1)
            assert np.all(touch[~in_band] == 1) and ((apart & in_band).any() or numba.config.NUMBA_NUM_THREADS == 1)
            assert np.all(rows[apart | ~in_band] == 7.0) and np.all(rows[~apart & in_band] != 7.0)
        # a force on each particle in contact, none on the others (on several threads the shares of the band's
        # particles wait in the rows: a force on them only from their own pairs)
        touching = np.zeros(n, dtype=bool)
        touching[owner[~apart]] = True
        touching[nbr.j[~apart & ~in_band]] = True
        assert np.all(np.any(s.f[touching] != 0.0, axis=1)) and np.all(s.f[~touching] == 0.0)


def _copy_list(nbr):
    return type(nbr)(*(a.copy() for a in nbr))


def test_the_live_byte_follows_contacts_and_the_rebuild_and_changes_no_result():
    """A pair's live byte (engine/neighbor.py NeighborList) is 1 after a pass that found it in contact, 0 after one
    that found it apart; a pair whose byte is 0 has its history row neither read nor written when found apart
    (kernels.RESET_PAIR_HISTORY); the rebuild sets it exactly where the carried row's bits are not zero (a +0.0
    carried by a pair whose i and j swapped is -0.0: 1). Over passes in which pairs touch, separate and touch
    again, the forces, torques and histories are the same bytes as those of the same passes testing every row
    (every byte 1, the way before the byte existed)."""
    import numba

    from engine import state as particle_state
    from engine.neighbor import empty_list, lost_record, rebuild, start_band

    rng = np.random.default_rng(5)
    n = 1500
    lo, hi = np.zeros(3), np.array([0.1, 0.1, 0.1])
    x0 = lo + rng.random((n, 3)) * (hi - lo)
    radius = np.full(n, 0.003)
    mass = 2500.0 * 4.0 / 3.0 * np.pi * radius ** 3
    materials = {1: (1e7, 0.3, 2500.0)}
    inter = {(1, 1): {"restitution": 0.5, "friction": 0.3, "rolling_friction": 0.0, "cohesion_energy_density": 0.0}}
    periodic = np.zeros(3, dtype=np.bool_)
    for parallel in (False, True):
        c = Combination(normal="hertz", tangential="history", parallel=parallel)
        module = kernels.build_kernel(c)
        pp = parameter_table(c, materials, inter, 1)
        s = particle_state.append(particle_state.empty(0, 3), x=x0.copy(), radius=radius, mass=mass,
                                  inv_mass=1.0 / mass, inv_inertia=1.0 / (0.4 * mass * radius ** 2),
                                  pid=np.arange(1, n + 1), v=0.01 * rng.standard_normal((n, 3)),
                                  x_build=x0.copy(), omega=np.ones((n, 3)))
        kept, nbr = rebuild(s, n, empty_list(3, c.reaction_width), lo, hi, periodic, 0.002, 1, lost_record(n),
                            -np.ones(3))
        assert kept == n and np.all(nbr.live == 0)  # new pairs: history +0.0
        owner = np.repeat(np.arange(n), np.diff(nbr.start))
        home = s.x.copy()
        swing = 0.002 * rng.standard_normal((n, 3))
        old = _copy_list(nbr)
        contact = []
        for step in range(8):
            s.x[:] = home + np.sin(1.3 * step) * swing  # pairs close, part and close again
            results = []
            for lst in (nbr, old):
                if lst is old:
                    lst.live[:] = 1  # the former pass: every history row's bits tested
                s.f[:] = 0.0
                s.torque[:] = 0.0
                if parallel:  # every thread of the pool: a boundary band (engine/neighbor.py start_band)
                    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
                    start_band(lst, n, kernels.PAIR_BLOCK, s.f, s.torque)
                module.pair_forces(s, n, lst, pp, 1e-5, 1.0, hi - lo)
                results.append((s.f.copy(), s.torque.copy(), lst.hist.copy()))
            for new, before in zip(*results):
                assert new.tobytes() == before.tobytes()
            d = np.linalg.norm(s.x[owner] - s.x[nbr.j], axis=1)
            touching = d < radius[owner] + radius[nbr.j]
            assert np.array_equal(nbr.live, touching.astype(np.uint8))
            contact.append(touching)
        contact = np.array(contact)
        # some pair touched, separated and touched again
        assert np.any(contact[:-2] & ~contact[1:-1] & contact[2:])
        # a pair apart whose byte says +0.0 is not looked at: a nonzero row stays as it is
        k = np.nonzero(~contact[-1])[0][0]
        nbr.hist[k] = 1.0
        s.f[:] = 0.0
        if parallel:
            start_band(nbr, n, kernels.PAIR_BLOCK, s.f, s.torque)
        module.pair_forces(s, n, nbr, pp, 1e-5, 1.0, hi - lo)
        assert np.all(nbr.hist[k] == 1.0) and nbr.live[k] == 0
        nbr.hist[k] = 0.0
        # the rebuild after the particles moved: pairs found again carry their rows and bytes, some swapped
        old_pid = s.pid.copy()  # the ids of the rows before the rebuild re-orders them
        before = {(min(a, b), max(a, b)) for a, b, t in zip(old_pid[owner], old_pid[nbr.j], contact[-1]) if t}
        s.x[:] += 0.01 * rng.random((n, 3))
        s.x[:] = np.clip(s.x, lo + 1e-9, hi - 1e-9)
        s_all, nbr_all = type(s)(*(a.copy() for a in s)), _copy_list(nbr)
        nbr_all.live[:] = 1  # every old row read, as before the byte
        kept, fresh = rebuild(s, n, nbr, lo, hi, periodic, 0.002, 2, lost_record(n), -np.ones(3))
        _, fresh_all = rebuild(s_all, n, nbr_all, lo, hi, periodic, 0.002, 2, lost_record(n), -np.ones(3))
        assert fresh.hist.tobytes() == fresh_all.hist.tobytes()
        nonzero = np.any(fresh.hist.view(np.uint64) != 0, axis=1)
        assert kept == n and np.all(fresh.live[nonzero] == 1) and np.any(fresh.live == 0)
        negative_zero = np.all(fresh.hist == 0.0, axis=1) & nonzero
        assert negative_zero.any() and np.any(fresh.hist != 0.0)
        # a byte 1 only where a pair was found in contact at the last pass, or carried -0.0
        was_touching = np.zeros(len(fresh.j), dtype=bool)
        pid = s.pid
        for i in range(n):
            for k in range(fresh.start[i], fresh.start[i + 1]):
                a, b = pid[i], pid[fresh.j[k]]
                was_touching[k] = (min(a, b), max(a, b)) in before
        assert np.array_equal(fresh.live == 1, was_touching | negative_zero)


def test_a_particle_with_no_plane_in_reach_reads_neither_radius_nor_type_in_the_particle_pass():
    """kernels.WALL_REACH: with planes as the only walls, radius[i] and ptype[i] are read in the particle pass only
    under the test of the plane bits; with another shape of wall they are read for every particle."""
    def particle_pass(c):
        source = generate_source(c)
        start = source.index("def particle_pass")
        return source[start:source.index("\n@", start)]
    planes = particle_pass(Combination(normal="hertz", tangential="history", planes=True, gravity=True))
    guarded = re.search(r"\n( +)if plane_near\[i\] != 0 or nplanes > PLANE_BITS:\n\1    ri = radius\[i\]\n"
                        r"\1    ti = ptype\[i\]\n", planes)
    assert guarded and planes.count("radius[i]") == 1 and planes.count("ptype[i]") == 1
    both = particle_pass(Combination(normal="hertz", tangential="history", planes=True, cylinders=True))
    assert "if plane_near[i] != 0 or nplanes" not in both and re.search(r"\n +ri = radius\[i\]\n", both)


def test_interleaved_fields_are_views_of_their_block_in_python_and_in_compiled_code():
    """engine/state.py BLOCKS: a field of a block reads and writes the block's columns, through the Python
    property and through the attribute in compiled code alike; the other fields keep their own arrays. Appending,
    taking and re-ordering keep every field's values (the same values as without blocks)."""
    from engine import state as particle_state
    from engine.jit import njit

    rng = np.random.default_rng(5)
    n = 7
    values = {f.name: rng.random((n,) + tuple(3 if d == "walls" else 2 if d == "history" else d for d in f.shape))
              .astype(f.dtype) for f in particle_state.PARTICLE_FIELDS}
    s = particle_state.append(particle_state.empty(3, 2), **values)
    assert set(particle_state.BLOCKS) <= set(s._fields) and "x" not in s._fields and "pid" in s._fields
    for name, value in values.items():
        assert np.array_equal(getattr(s, name), value), name
    block, first, width, scalar = particle_state.COLUMNS["v"]
    assert np.shares_memory(s.v, getattr(s, block)) and np.array_equal(getattr(s, block)[:, first:first + 3], s.v)

    @njit
    def scale_v_and_read_radius(s, factor):
        v = s.v
        total = 0.0
        for i in range(v.shape[0]):
            v[i, 1] *= factor
            total += s.radius[i]
        return total

    assert scale_v_and_read_radius(s, 2.0) == sum(values["radius"].tolist())
    assert np.array_equal(s.v[:, 1], 2.0 * values["v"][:, 1]) and np.array_equal(s.v[:, 0], values["v"][:, 0])
    order = np.array([6, 0, 5, 1, 4, 2, 3])
    taken = particle_state.take(s, order)
    particle_state.reorder(s, order)
    for name in particle_state.FIELD_NAMES:
        assert np.array_equal(getattr(s, name), getattr(taken, name)), name
    assert np.array_equal(s.x, values["x"][order]) and np.array_equal(s.pid, values["pid"][order])
    # machine code compiled for a state is keyed by the layout and by the code that makes s.x a view
    from numba import typeof

    from engine.jit import _record_fields, content_key
    named = []
    _record_fields((typeof(s),), named)
    assert named[0].endswith(content_key(particle_state._attribute_in_compiled_code))
    assert "('xr', (('x', 'radius'), 4))" in named[0] and "('hot', (('v', 'omega', 'mass'), 7))" in named[0]


def test_the_compiled_kernels_index_the_blocks_by_constant_columns():
    """What compiles (kernels.laid_out) reads and writes a field of a block as its column, x[j, 1] as xr[j, 1],
    in every function that binds the blocks; only the source as generated names the fields."""
    from engine import state as particle_state

    named = generate_source(Combination(normal="hertz", tangential="history", planes=True, gravity=True))
    compiled = kernels.laid_out(named)
    fields = "|".join(particle_state.COLUMNS)
    assert re.search(rf"\b({fields})\[[a-z]+, [0-9]\]", named)
    assert not re.search(rf"\b({fields})\[[a-z]+(, [0-9])?\]", compiled)
    for name, (block, first, width, scalar) in particle_state.COLUMNS.items():
        for column in range(width):
            if (f"{name}[j]" if scalar else f"{name}[j, {column}]") in named:
                assert f"{block}[j, {first + column}]" in compiled
    assert "dx = xi0 - xr[j, 0]" in compiled
