"""Arithmetic in ${...} variables (issue 12): expressions over the -var variables, plain ${NAME} unchanged.

A scene that sizes its geometry from a few variables (`"${0.5*D}"`, `"-${W/2}"`) must get exactly the number
Python's arithmetic gives, an int where every operand is an int and the value is integral (counts, steps), and
one ERROR line naming file, command and expression for anything that is not a number.
"""
import math

import pytest

from conftest import domain, interaction, material, model, particle, run, timestep
from engine.errors import InputError
from engine.script import evaluate_expression, substitute

WHERE = "scene.json: command 4 (create particle)"
VARIABLES = {"D": "0.04", "d": "0.002", "W": "0.02", "N": "10", "M": "7", "T": "abc", "BIG": "1e400"}


@pytest.mark.parametrize("text, value", [
    ("${0.5*D}", 0.5 * 0.04),
    ("${D - 1.4*d}", 0.04 - 1.4 * 0.002),
    ("-${W/2}", -0.01),
    ("${N/2}", 5),              # integral, every operand an int: an int
    ("${M/2}", 3.5),
    ("${0.5*N}", 5.0),          # a float operand: a float
    ("${N*N + 1}", 101),
    ("${2**N}", 1024),
    ("${N // 3}", 3),
    ("${N % 3}", 1),
    ("${sqrt(16)}", 4),
    ("${sqrt(2)}", math.sqrt(2)),
    ("${pi*D}", math.pi * 0.04),
    ("${max(N, M) - min(N, M)}", 3),
    ("${abs(-D)}", 0.04),
    ("${floor(M/2)}", 3),
    ("${exp(0) + log(1) + sin(0) + cos(0) + tan(0)}", 2),  # integral, int operands
    ("${exp(0.0)}", 1.0),
    ("${ N }", 10),            # spaces make it an expression: same number
    ("${1e-7*N}", 1e-06),
    ("${N}e-3", 0.01),         # plain names stay text substitution
    ("${2*N}e-3", 0.02),       # an expression's repr embedded in text
])
def test_expressions_give_the_number_python_gives(text, value):
    got = substitute(text, VARIABLES, WHERE)
    assert got == value and type(got) is type(value), (text, got)


def test_embedded_expressions_keep_every_digit():
    # repr, not str or %g: 0.1 * 3 = 0.30000000000000004 survives the round trip through the text
    assert substitute("${0.1*3}", {}, WHERE) == 0.1 * 3
    assert substitute("-${0.1*3}", {}, WHERE) == -(0.1 * 3)
    assert substitute("[${N/4}]", VARIABLES, WHERE) == "[2.5]"


@pytest.mark.parametrize("text, value", [
    ("${N}", 10), ("${T}", "abc"), ("x${T}y", "xabcy"), ("-${W}", -0.02), ("${}", "${}"), ("no variable", "no variable"),
    ("$N", "$N"),
])
def test_plain_names_behave_as_before(text, value):
    got = substitute(text, VARIABLES, WHERE)
    assert got == value and type(got) is type(value)


def test_nested_values_are_substituted():
    got = substitute({"lo": ["-${W/2}", 0, "${N}"], "k": {"r": "${0.5*d}"}}, VARIABLES, WHERE)
    assert got == {"lo": [-0.01, 0, 10], "k": {"r": 0.001}}


@pytest.mark.parametrize("text, message", [
    ("${N/0}", "expression '${N/0}' divides by zero"),
    ("${N % 0}", "divides by zero"),
    ("${Q + 1}", "expression '${Q + 1}': unknown name 'Q' (pass -var Q VALUE"),
    ("${N +}", "expression '${N +}' is not valid arithmetic"),
    ("${T*2}", "variable T = 'abc' is not a finite number"),
    ("${BIG*2}", "variable BIG = '1e400' is not a finite number"),
    ("${N^2}", "uses an operator that is not arithmetic"),
    ("${N > 1}", "uses Python syntax that is not arithmetic (Compare)"),
    ("${N.real}", "(Attribute)"),
    ("${'a'}", "holds 'a': only numbers"),
    ("${(True)}", "holds True"),
    ("${True}", "variable '${True}' has no value"),  # a plain name: a variable
    ("${foo(1)}", "calls unknown function 'foo'"),
    ("${sqrt(x=1)}", "calls something other than a function by name"),
    ("${log(0)}", "cannot be evaluated (ValueError"),
    ("${10.0**400}", "cannot be evaluated (OverflowError"),
    ("${2**99999999}", "cannot be evaluated (NumberTooHigh"),
    ("x ${N/0} y", "divides by zero"),
])
def test_bad_expressions_are_bad_input_naming_command_and_expression(text, message):
    with pytest.raises(InputError) as err:
        substitute(text, VARIABLES, WHERE)
    assert str(err.value).startswith(WHERE + ": ") and message in str(err.value), str(err.value)
    assert "\n" not in str(err.value)


def test_evaluate_expression_directly():
    assert evaluate_expression("D/2", VARIABLES, WHERE) == 0.02
    assert evaluate_expression("N*3", VARIABLES, WHERE) == 30


def _scene(radius, position_z):
    return [domain(), material(), interaction(), model("hertz", "history"),
            particle([0, 0, position_z], radius=radius), timestep(1e-5),
            {"command": "get", "property": "z[1]"}, run("${STEPS - 10}")]


def test_a_scene_sized_by_expressions(engine_run):
    code, folder = engine_run(_scene("${0.5*D}", "-${W/2}"), {"D": 0.04, "W": 0.02, "STEPS": 12})
    assert code == 0
    log = (folder / "log.dem").read_text()
    assert "z[1] = -0.01" in log
    assert "total: 2 steps, 1 particles" in log


def test_a_bad_expression_in_a_scene_is_one_error_line(engine_run):
    code, folder = engine_run(_scene("${0.5*D}", "${W/0}"), {"D": 0.04, "W": 0.02, "STEPS": 12})
    assert code == 2
    last = (folder / "log.dem").read_text().splitlines()[-1]
    assert last == "ERROR: scene.json: command 5 (create): expression '${W/0}' divides by zero"
