"""Expectations and stability checks of run configurations (harness.config.acceptance)."""
import numpy as np
import pandas as pd
import pytest

from harness.config.acceptance import evaluate, problems
from harness.config.check import validate as validate_schema
from harness.config.runconfig import RunConfigEntry
from harness.config.jsonfile import json_path


def validate(entry: dict) -> list[str]:
    """The problems of a run configuration's acceptance keys (the schema's and the rules between bounds), as
    ``PATH: message`` with the path inside the entry."""
    found = validate_schema(RunConfigEntry, {"name": "r", "script": "s.json", **entry})[1] + problems(entry)
    return [f"{json_path(*p.path)[2:]}: {p.message}" for p in found]


def thermo(**columns):
    n = len(next(iter(columns.values())))
    return pd.DataFrame({"step": np.arange(n) * 100, **columns})


def failed(verdicts):
    return [v for v in verdicts if not v.ok]


def test_expectation_within_relative_tolerance_passes_and_outside_fails():
    data = {"restitution": pd.DataFrame({"index": [0], "e": [0.905]})}
    ok = evaluate({"expectations": [{"quantity": "restitution.e", "value": 0.9, "rel_tol": 0.01}]}, data)
    assert not failed(ok)
    bad = evaluate({"expectations": [{"quantity": "restitution.e", "value": 0.9, "rel_tol": 0.001}]}, data)
    (verdict,) = failed(bad)
    assert verdict.reason == "expectation"
    # the message names the quantity, the measured value and the bound
    assert "restitution.e" in verdict.message and "0.905" in verdict.message and "0.8991" in verdict.message


def test_an_expectation_holds_for_the_engines_it_names():
    # one run configuration for several codes: the rebound of a clump damped with its member's mass (YADE)
    # and with the clump's mass (the engine, LIGGGHTS) are each stated for their codes (testcases/shapes)
    data = {"bounce": pd.DataFrame({"step": [0, 1], "ke": [1.3e-3, 3.96e-4]})}
    entry = {"expectations": [
        {"quantity": "bounce.ke", "value": 1.7536e-4, "rel_tol": 0.001, "engines": ["dem", "liggghts"]},
        {"quantity": "bounce.ke", "value": 3.96e-4, "rel_tol": 0.001, "engines": ["yade"]}]}
    assert not validate(entry)
    assert not failed(evaluate(entry, data, engine="yade"))
    (verdict,) = failed(evaluate(entry, data, engine="dem"))
    assert "1.7536e-04" in verdict.message or "0.00017536" in verdict.message
    assert len(evaluate(entry, data, engine="lammps")) == len(evaluate({}, data))   # none of its engines
    assert len(failed(evaluate(entry, data))) == 1                                   # engine unknown: all
    assert validate({"expectations": [{"quantity": "bounce.ke", "upper": 1, "engines": "yade"}]}) == [
        "expectations[0].engines: must be a list of engine adapter names, got string \"yade\""]


@pytest.mark.parametrize("at,expected", [("end", 3.0), ("start", 1.0), ("min", 0.5), ("max", 4.0), ("mean", 2.125)])
def test_reductions(at, expected):
    data = {"thermo": thermo(ke=[1.0, 4.0, 0.5, 3.0])}
    spec = {"quantity": "thermo.ke", "at": at, "value": expected, "abs_tol": 1e-12}
    assert not failed(evaluate({"expectations": [spec]}, data))
    spec["value"] = expected + 0.01
    assert failed(evaluate({"expectations": [spec]}, data))


def test_sum_of_terms_and_upper_bound():
    data = {"thermo": thermo(ke=[1.0, 2.0], rke=[0.5, 0.5])}
    assert not failed(evaluate({"expectations": [{"quantity": "thermo.ke + thermo.rke", "upper": 2.5}]}, data))
    (verdict,) = failed(evaluate({"expectations": [{"quantity": "thermo.ke+thermo.rke", "upper": 2.4}]}, data))
    assert "2.5" in verdict.message


def test_missing_series_or_column_fails_with_names():
    data = {"thermo": thermo(ke=[1.0])}
    (v,) = failed(evaluate({"expectations": [{"quantity": "thermo.pe", "upper": 1}]}, data))
    assert "no column 'pe'" in v.message and "ke" in v.message
    (v,) = failed(evaluate({"expectations": [{"quantity": "bounce.e", "upper": 1}]}, data))
    assert "no series 'bounce'" in v.message


def test_non_finite_values_fail_naming_column_and_step():
    data = {"thermo": thermo(ke=[1.0, np.nan, 2.0])}
    (v,) = failed(evaluate({}, data))
    assert v.reason == "stability" and "thermo.ke" in v.message and "step 100" in v.message
    assert not failed(evaluate({"stability": {"finite": False}}, data))


def test_particle_count_conserved_or_losses_bounded():
    data = {"thermo": thermo(atoms=[100, 100, 98, 98])}
    (v,) = failed(evaluate({"stability": {"particle_count": {}}}, data))
    assert "lost 2" in v.message and "at 200" in v.message
    assert not failed(evaluate({"stability": {"particle_count": {"max_loss": 2}}}, data))


def test_energy_never_grows_catches_a_rise_above_the_running_minimum():
    decaying = {"thermo": thermo(ke=[10.0, 8.0, 8.05, 5.0, 4.0])}
    # a rise of 0.05 on a scale of 10 is inside 1 %, outside 0.1 %
    assert not failed(evaluate({"stability": {"energy_never_grows": {"quantity": "thermo.ke", "rel_tol": 0.01}}},
                               decaying))
    (v,) = failed(evaluate({"stability": {"energy_never_grows": {"quantity": "thermo.ke", "rel_tol": 0.001}}},
                           decaying))
    assert "at 200" in v.message
    # energy growing during insertion is skipped with 'after'
    filling = {"thermo": thermo(ke=[0.0, 5.0, 10.0, 6.0, 3.0])}
    spec = {"quantity": "thermo.ke", "rel_tol": 0.0}
    assert failed(evaluate({"stability": {"energy_never_grows": spec}}, filling))
    assert not failed(evaluate({"stability": {"energy_never_grows": {**spec, "after": 200}}}, filling))


def test_energy_drift_and_max_overlap():
    data = {"thermo": thermo(etotal=[1.0, 1.001, 0.999, 1.02], max_overlap=[0.0, 0.02, 0.11, 0.01])}
    assert failed(evaluate({"stability": {"energy_drift": {"quantity": "thermo.etotal", "rel_tol": 0.01}}}, data))
    assert not failed(evaluate({"stability": {"energy_drift": {"quantity": "thermo.etotal", "rel_tol": 0.05}}}, data))
    (v,) = failed(evaluate({"stability": {"max_overlap": {"quantity": "thermo.max_overlap", "upper": 0.1}}}, data))
    assert "0.11" in v.message and "at 200" in v.message


def test_validate_names_the_json_path():
    assert validate({"expectations": [{"quantity": "thermo.ke", "value": 1, "rel_tol": 0.1}]}) == []
    errors = validate({"expectations": [{"quantity": "ke", "at": "last", "value": 1}],
                       "stability": {"energy_never_grows": {"quantity": "thermo.ke"}, "explode": {}}})
    text = "\n".join(errors)
    assert "expectations[0].quantity" in text
    assert "expectations[0].at: must be one of" in text
    assert "expectations[0]: 'value' needs 'rel_tol' or 'abs_tol'" in text
    assert "stability.energy_never_grows: needs 'rel_tol' or 'abs_tol'" in text
    assert "stability.explode: unknown check" in text
    assert validate({"expectations": {"a": 1}}) == ['expectations: must be a list of objects, got object {"a": 1}']
    assert "expectations[0].rel_tol: must be >= 0" in "\n".join(
        validate({"expectations": [{"quantity": "a.b", "value": 1, "rel_tol": -1}]}))
