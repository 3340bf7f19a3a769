"""Scoring after thesis eqs. 4.2-4.4 and the additions (floor, overrides, first bad step, length mismatch)."""
import math

import numpy as np
import pytest

from harness.analysis.consistency import (
    GOOD,
    INCONSISTENT,
    LENGTH_MISMATCH,
    MISSING,
    PERFECT,
    compare_runs,
    compare_trajectory,
    compare_words,
    level_of,
    run_level,
    score,
)


def loop_score(ref, x):
    """Eqs. 4.2-4.4 written out point by point, as in the thesis, to check the vectorised version."""
    eps = 0.1 * (max(ref) - min(ref)) / 2
    worst = 0.0
    for a, b in zip(ref, x):
        worst = max(worst, 0.1 * abs(b - a) / eps)
    return 1 - worst


def test_score_matches_the_thesis_formula_on_a_hand_example():
    ref = [0.0, 1.0, 2.0, 4.0]        # eps = 0.1 * 4 / 2 = 0.2
    run = [0.0, 1.1, 2.0, 4.0]        # Delta = 0.1 * 0.1 / 0.2 = 0.05 -> C = 0.95
    s = score(ref, run)
    assert s.epsilon == pytest.approx(0.2)
    assert s.value == pytest.approx(0.95)
    assert s.level == PERFECT
    assert s.first_bad is None


def test_levels_at_five_and_ten_percent():
    assert level_of(0.96) == PERFECT
    assert level_of(0.94) == GOOD
    assert level_of(0.9) == GOOD
    assert level_of(0.89) == INCONSISTENT
    ref = np.linspace(0, 10, 11)      # eps = 0.5; a deviation of 0.7 -> Delta 0.14 -> C 0.86
    run = ref.copy()
    run[6] += 0.7
    s = score(ref, run)
    assert s.value == pytest.approx(0.86)
    assert s.level == INCONSISTENT
    assert s.first_bad == 6


def test_vectorised_score_equals_point_by_point_loop():
    rng = np.random.default_rng(1)
    ref = np.cumsum(rng.normal(size=2000))
    run = ref + rng.normal(scale=0.05, size=2000)
    assert score(ref, run).value == pytest.approx(loop_score(ref, run), rel=1e-12)


def test_flat_reference_uses_the_floor():
    ref = np.full(50, 1000.0)         # a constant particle count: max = min
    same = score(ref, ref.copy())
    assert same.value == 1.0 and same.level == PERFECT
    lost_one = ref.copy()
    lost_one[20:] = 999.0
    s = score(ref, lost_one)          # default floor 1e-6 * 1000 = 1e-3: one particle lost is inconsistent
    assert s.epsilon == pytest.approx(1e-3)
    assert s.level == INCONSISTENT and s.first_bad == 20
    tolerant = score(ref, lost_one, floor=20.0)   # Delta = 0.1 * 1 / 20 = 0.005
    assert tolerant.value == pytest.approx(0.995)
    assert score(np.zeros(5), np.zeros(5)).value == 1.0
    assert score(np.zeros(5), np.array([0, 0, 1e-9, 0, 0])).level == INCONSISTENT


def test_epsilon_override_replaces_eq_4_2():
    s = score([0.0, 1.0], [0.0, 1.5], epsilon=5.0)   # Delta = 0.1 * 0.5 / 5 = 0.01
    assert s.value == pytest.approx(0.99)
    assert s.epsilon == 5.0


def test_nan_in_the_run_is_inconsistent_but_stays_a_finite_number():
    s = score([0.0, 1.0, 2.0], [0.0, float("nan"), 2.0])
    assert s.level == INCONSISTENT and math.isfinite(s.value) and s.first_bad == 1


def test_first_bad_step_reported_on_the_step_axis():
    steps = np.arange(0, 1000, 10)
    ref = np.sin(steps / 100.0)
    run = ref.copy()
    run[steps >= 730] += 0.5
    r = compare_trajectory("thermo", "thermo", "ke", steps, ref, steps, run)
    assert r.level == INCONSISTENT
    assert r.first_bad_step == 730
    assert "730" in r.message


def test_a_run_that_stopped_early_is_a_length_mismatch():
    steps = np.arange(0, 100)
    ref = steps * 2.0
    r = compare_trajectory("thermo", "thermo", "ke", steps, ref, steps[:60], ref[:60])
    assert r.level == LENGTH_MISMATCH
    assert r.value == pytest.approx(1.0)      # consistent on the common steps
    assert "run stopped at step 59" in r.message and "60 points vs 100" in r.message


def test_words_compare_numbers_with_tolerance_and_words_exactly():
    ref = "restitution 0.90 after 3 bounces".split()
    assert compare_words("r.txt", ref, "restitution 0.90 after 3 bounces".split()).level == PERFECT
    near = compare_words("r.txt", ref, "restitution 0.93 after 3 bounces".split())  # 3.3 % off
    assert near.level == PERFECT and near.value == pytest.approx(1 - 0.1 * 0.03 / 0.09)
    far = compare_words("r.txt", ref, "restitution 1.2 after 3 bounces".split())
    assert far.level == INCONSISTENT and "1.2" in far.message
    word = compare_words("r.txt", ref, "restitution 0.90 before 3 bounces".split())
    assert word.level == INCONSISTENT and "'before'" in word.message
    assert compare_words("r.txt", ref, ref[:-1]).level == INCONSISTENT


def _thermo(steps, **columns):
    return {"kind": "thermo", "name": "thermo", "x_column": "step",
            "columns": {"step": list(steps), **{k: list(v) for k, v in columns.items()}}}


def test_compare_runs_covers_thermo_plots_textfiles_and_overrides():
    steps = range(0, 100, 10)
    ke = [float(s) for s in steps]
    ref = [_thermo(steps, ke=ke, atoms=[10] * 10, cpu=[0.1 * s for s in steps]),
           {"kind": "plot", "name": "torque", "x_column": "d.t", "columns": {"d.t": [0, 1, 2], "d.T": [1, 2, 3]}},
           {"kind": "textfile", "name": "out.txt", "x_column": "", "columns": {"words": ["e", "0.5"]}}]
    run = [_thermo(steps, ke=[k * 1.5 for k in ke], atoms=[10] * 10, cpu=[9.0] * 10),
           {"kind": "plot", "name": "torque", "x_column": "d.t", "columns": {"d.t": [0, 1, 2], "d.T": [1, 2, 3]}},
           {"kind": "textfile", "name": "out.txt", "x_column": "", "columns": {"words": ["e", "0.5"]}}]
    results = {(r.series_name, r.quantity): r for r in compare_runs(run, ref)}
    assert set(results) == {("thermo", "ke"), ("thermo", "atoms"), ("torque", "d.T"), ("out.txt", "words")}
    assert results[("thermo", "ke")].level == INCONSISTENT          # cpu time is never compared
    assert results[("torque", "d.T")].level == PERFECT
    assert run_level(list(results.values()))[0] == INCONSISTENT
    relaxed = compare_runs(run, ref, {"ke": {"epsilon": 1000.0}})
    assert all(r.level == PERFECT for r in relaxed)
    ignored = compare_runs(run, ref, {"ke": {"ignore": True}})
    assert ("thermo", "ke") not in {(r.series_name, r.quantity) for r in ignored}
    missing = compare_runs(run[:1], ref)
    assert {r.level for r in missing if r.series_kind != "thermo"} == {MISSING}
    other_code = compare_runs([_thermo(steps, ke=ke, atoms=[10] * 10)],
                              [_thermo(steps, ke=ke, atoms=[10] * 10, rke=[0.0] * 10, com_z=ke)])
    assert {(r.quantity, r.level) for r in other_code} == {("ke", PERFECT), ("atoms", PERFECT), ("rke", MISSING)}


def test_different_output_interval_is_scored_on_common_steps():
    ref_steps = np.arange(0, 101, 10)
    run_steps = np.arange(0, 101, 20)
    r = compare_trajectory("thermo", "thermo", "ke", ref_steps, ref_steps * 1.0, run_steps, run_steps * 1.0)
    assert r.level == LENGTH_MISMATCH and r.value == pytest.approx(1.0)
    assert "steps differ" in r.message and "6 common steps" in r.message
