"""JSON command scripts (after seed 003): loading, ``${NAME}`` variables, and validated field access.

A script is a JSON list of objects, each with a ``command`` (create, get, set, fix, unfix, run) and fields.
``${NAME}`` anywhere in a string is replaced by the value given with ``-var NAME VALUE``; a string that held
a variable becomes a number when the filled-in text parses as one (``"${N}"``, ``"-${HALF_WIDTH}"``).
``${...}`` holding more than a name is an arithmetic expression over the variables (``"${0.5*D}"``,
``"-${W/2}"``), evaluated with simpleeval restricted to numbers (`evaluate_expression`).
"""
from __future__ import annotations

import ast
import json
import math
import operator
import re
from pathlib import Path

import simpleeval

from .errors import InputError

COMMANDS = ("create", "get", "set", "fix", "unfix", "run")
#: axis names of scripts (walls, quantities) -> index
AXES = {"x": 0, "y": 1, "z": 2}
#: largest integer field (step counts, intervals, seeds): the step loop counts in int64, and 2**53 keeps every
#: step exactly representable as the double a thermo file prints
MAX_INTEGER = 2 ** 53
_VARIABLE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")
#: ${...} with anything but braces inside: a plain name (text substitution) or an expression
_BRACED = re.compile(r"\$\{([^{}]*)\}")

#: what an expression may use: arithmetic on numbers, these functions and pi (simpleeval evaluates the AST
#: with exactly these; comparisons, bit operations, strings, attributes and subscripts are refused)
EXPRESSION_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
                        ast.Div: operator.truediv, ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod,
                        ast.Pow: simpleeval.safe_power, ast.USub: operator.neg, ast.UAdd: operator.pos}
EXPRESSION_FUNCTIONS = {"sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan, "exp": math.exp,
                        "log": math.log, "min": min, "max": max, "abs": abs, "floor": math.floor,
                        "ceil": math.ceil, "round": round}
EXPRESSION_CONSTANTS = {"pi": math.pi}
_ALLOWED = (f"only numbers, variables, + - * / // % ** ( ), {', '.join(EXPRESSION_FUNCTIONS)} and pi are "
            "allowed")


def _number_or_text(text: str):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _operand_value(name: str, variables: dict[str, str], expression: str, where: str):
    """The number a name stands for in an expression: a -var variable (which must read as a number) or pi."""
    if name in variables:
        value = _number_or_text(variables[name])
        if isinstance(value, str) or (isinstance(value, float) and not math.isfinite(value)):
            raise InputError(f"{where}: expression '${{{expression}}}': variable {name} = '{variables[name]}' "
                             "is not a finite number")
        return value
    if name in EXPRESSION_CONSTANTS:
        return EXPRESSION_CONSTANTS[name]
    raise InputError(f"{where}: expression '${{{expression}}}': unknown name '{name}' (pass -var {name} VALUE; "
                     f"functions: {', '.join(EXPRESSION_FUNCTIONS)}; constant: pi)")


def evaluate_expression(expression: str, variables: dict[str, str], where: str):
    """The number of an arithmetic expression over the -var variables, e.g. ``0.5*D`` or ``D - 1.4*d``.

    An int when the value is integral and every operand (literal or variable) is an int (``${N/2}`` with
    N = 10 gives 5, ``${0.5*N}`` gives 5.0), else a float. Unknown names, syntax errors, division by zero,
    non-numeric or non-finite results are InputError naming the command (where) and the expression.
    """
    def fail(reason: str) -> InputError:
        return InputError(f"{where}: expression '${{{expression}}}' {reason}")

    try:
        tree = ast.parse(expression.strip(), mode="eval")
    except SyntaxError as exc:
        raise fail(f"is not valid arithmetic ({exc.msg})") from None
    calls = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
    names, all_ints = {}, True
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            if id(node) in calls:
                continue  # a function's name, checked with its call
            names[node.id] = _operand_value(node.id, variables, expression, where)
            all_ints = all_ints and isinstance(names[node.id], int)
        elif isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise fail(f"holds {node.value!r}: {_ALLOWED}")
            all_ints = all_ints and isinstance(node.value, int)
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.keywords:
                raise fail(f"calls something other than a function by name: {_ALLOWED}")
            if node.func.id not in EXPRESSION_FUNCTIONS:
                raise fail(f"calls unknown function '{node.func.id}' (functions: "
                           f"{', '.join(EXPRESSION_FUNCTIONS)})")
        elif isinstance(node, (ast.BinOp, ast.UnaryOp)):
            if type(node.op) not in EXPRESSION_OPERATORS:
                raise fail(f"uses an operator that is not arithmetic: {_ALLOWED}")
        elif not isinstance(node, (ast.Expression, ast.Load, ast.operator, ast.unaryop)):
            raise fail(f"uses Python syntax that is not arithmetic ({type(node).__name__}): {_ALLOWED}")
    evaluator = simpleeval.SimpleEval(operators=EXPRESSION_OPERATORS, functions=EXPRESSION_FUNCTIONS, names=names)
    try:
        value = evaluator.eval(expression.strip())
    except ZeroDivisionError:
        raise fail("divides by zero") from None
    except (simpleeval.InvalidExpression, ValueError, TypeError, OverflowError, ArithmeticError) as exc:
        raise fail(f"cannot be evaluated ({type(exc).__name__}: {exc})") from None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(f"gives {value!r}, not a number")
    if isinstance(value, float) and not math.isfinite(value):
        raise fail(f"gives {value!r}, not a finite number")
    if isinstance(value, int) and value.bit_length() > 1024:  # no double holds it (and its digits may not print)
        raise fail(f"gives an integer of {value.bit_length()} bits, beyond double precision")
    if all_ints and isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _fill(match, variables: dict[str, str], where: str) -> str:
    """The text a ${...} inside a longer string becomes: a variable's text, or an expression's repr."""
    content = match.group(1)
    if _VARIABLE.fullmatch(match.group(0)):
        return variables[content]
    if not content.strip():
        return match.group(0)  # "${}" was never a variable: left as text, as before expressions existed
    return repr(evaluate_expression(content, variables, where))


def substitute(value, variables: dict[str, str], where: str):
    """value with every ``${NAME}`` filled in and every ``${expression}`` evaluated; where names the command
    for error messages."""
    if isinstance(value, str):
        whole = _VARIABLE.fullmatch(value)
        for name in _VARIABLE.findall(value):
            if name not in variables:
                raise InputError(f"{where}: variable '${{{name}}}' has no value (pass -var {name} VALUE)")
        if whole:
            return _number_or_text(variables[whole.group(1)])
        expression = _BRACED.fullmatch(value)
        if expression and expression.group(1).strip():
            return evaluate_expression(expression.group(1), variables, where)
        if not _BRACED.search(value):
            return value
        # "-${W}", "${A}e-3" or "-${W/2}": a filled-in string that reads as a number is one
        filled = _BRACED.sub(lambda m: _fill(m, variables, where), value)
        if filled == value:
            return value
        return _number_or_text(filled)
    if isinstance(value, list):
        return [substitute(v, variables, where) for v in value]
    if isinstance(value, dict):
        return {k: substitute(v, variables, where) for k, v in value.items()}
    return value


#: deepest nesting of lists and objects a script may have; real scripts need 4 (list, command, region, list)
MAX_NESTING = 32


def _depth(value) -> int:
    """Nesting depth of parsed JSON, without recursion (a deep value must not exhaust the Python stack)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (list, dict)):
            depth += 1
            deepest = max(deepest, depth)
            if depth > MAX_NESTING:
                break
            stack.extend((v, depth) for v in (item.values() if isinstance(item, dict) else item))
    return deepest


def load_script(path: str, variables: dict[str, str]) -> list[dict]:
    """The command list of a script file (variables not yet filled in; that happens per command)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read input script ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
                         "scripts are JSON, which is UTF-8") from None
    try:
        commands = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except RecursionError:
        raise InputError(f"{path}: lists or objects nest deeper than the JSON parser allows "
                         f"(a script nests at most {MAX_NESTING} levels)") from None
    except ValueError as exc:  # e.g. an integer literal longer than Python's 4300-digit conversion limit
        raise InputError(f"{path}: not valid JSON: {exc}") from None
    if _depth(commands) > MAX_NESTING:
        raise InputError(f"{path}: lists or objects nest deeper than {MAX_NESTING} levels")
    if not isinstance(commands, list):
        raise InputError(f"{path}: the script must be a JSON list of command objects")
    return commands


def _real(value):
    """value as a finite float, or None when it is not a number or not representable (10**400, NaN, inf)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        value = float(value)
    except OverflowError:
        return None
    return value if math.isfinite(value) else None


def _shown(value) -> str:
    """A field value for an error message, kept short (a 5000-digit number must not make a 5000-char line)."""
    try:
        text = json.dumps(value)
    except (ValueError, RecursionError):
        text = repr(value)
    return text if len(text) <= 80 else text[:60] + "..." + text[-10:]


class Fields:
    """Typed, validated access to one command's fields; every error names file, command and field."""

    def __init__(self, data: dict, where: str):
        self.data = data
        self.where = where
        self.used = {"command"}

    def error(self, field: str, message: str) -> InputError:
        return InputError(f"{self.where}: field '{field}' {message}")

    def has(self, name: str) -> bool:
        return name in self.data

    def _get(self, name, default, required):
        self.used.add(name)
        if name not in self.data:
            if required:
                raise self.error(name, "is missing")
            return default
        return self.data[name]

    def number(self, name, default=None, required=False, positive=False, minimum=None, maximum=None,
               open_minimum=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        number = _real(value)
        if number is None:
            raise self.error(name, f"must be a number (finite, within double precision), got {_shown(value)}")
        value = number
        if positive and value <= 0:
            raise self.error(name, f"must be > 0, got {value:g}")
        if minimum is not None and (value <= minimum if open_minimum else value < minimum):
            raise self.error(name, f"must be {'>' if open_minimum else '>='} {minimum:g}, got {value:g}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be <= {maximum:g}, got {value:g}")
        return value

    def integer(self, name, default=None, required=False, minimum=None, maximum=MAX_INTEGER):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                raise self.error(name, f"must be an integer, got {_shown(value)}")
        if minimum is not None and value < minimum:
            raise self.error(name, f"must be >= {minimum}, got {_shown(value)}")
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be <= {maximum}, got {_shown(value)}")
        return value

    def string(self, name, default=None, required=False, choices=None):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, str):
            raise self.error(name, f"must be a string, got {_shown(value)}")
        if choices is not None and value not in choices:
            raise self.error(name, f"must be one of {', '.join(choices)}, got '{value}'")
        return value

    def output_path(self, name, default=None, required=False):
        """A file or folder the run writes: relative to the working folder and never leaving it (not absolute,
        no '..' part), so that a run writes only into its own folder."""
        value = self.string(name, default, required)
        if value is None:
            return None
        parts = value.replace("\\", "/").split("/")
        if not value or value.startswith("/") or ".." in parts:
            raise self.error(name, f"'{value[:200]}' leaves the working folder: an output path must be relative "
                             "and without '..'")
        return value

    def boolean(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if not isinstance(value, bool):
            raise self.error(name, f"must be true or false, got {_shown(value)}")
        return value

    def vector(self, name, length=3, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        numbers = [_real(v) for v in value] if isinstance(value, list) else []
        if len(numbers) != length or any(v is None for v in numbers):
            raise self.error(name, f"must be a list of {length} numbers (finite, within double precision), got "
                             f"{_shown(value)}")
        return numbers

    def strings(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.error(name, f"must be a list of strings, got {_shown(value)}")
        return value

    def mapping(self, name, default=None, required=False):
        value = self._get(name, default, required and default is None)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.error(name, f"must be an object, got {_shown(value)}")
        return value

    def raw(self, name, default=None, required=False):
        return self._get(name, default, required and default is None)

    def finish(self):
        """Unknown fields are errors too: a typo must not be silently ignored."""
        for name in self.data:
            if name not in self.used:
                raise self.error(name, "is not a field of this command")
