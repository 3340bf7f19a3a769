"""Kernel templates: plain text with named slots, filled by the kernel builder (`engine.kernels`) and by the
wall shapes (`engine.walls`) that own their part of the kernels.

A line holding only ``${name}`` is replaced by the slot's lines, indented as the slot is; ``${name}`` inside a
line by its text. A line slot given None is an optional hook left out: its line goes too, so that a template
with hooks for a feature (the clumps' slots in engine/kernels.py) gives, without the feature, the text of a
template that never had them.
"""
from __future__ import annotations

import re
import string

_BLOCK_SLOT = re.compile(r"^(?P<indent>[ ]*)\$\{(?P<name>\w+)\}[ ]*$(?P<end>\n?)", re.M)


def render(template: str, **slots) -> str:
    """template with its slots filled (module docstring); every slot must be given (None: a line slot left out
    with its line)."""
    def block(m):
        code = slots[m["name"]]
        if code is None:
            return ""
        return "\n".join(m["indent"] + line if line.strip() else "" for line in code.splitlines()) + m["end"]
    return string.Template(_BLOCK_SLOT.sub(block, template)).substitute(slots)


def unpack(obj: str, fields) -> str:
    """Fields of a state object as locals. Numba (0.68, issues 5872/7135) loses writes made through a
    namedtuple's attribute inside a parallel loop; locals are safe everywhere."""
    return "".join(f"{name} = {obj}.{name}\n" for name in fields)
