"""Kernel templates: plain text with named slots, filled by the kernel builder (`engine.kernels`) and by the
wall shapes (`engine.walls`) that own their part of the kernels.

A line holding only ``${name}`` is replaced by the slot's lines, indented as the slot is; ``${name}`` inside a
line by its text.
"""
from __future__ import annotations

import re
import string

_BLOCK_SLOT = re.compile(r"^(?P<indent>[ ]*)\$\{(?P<name>\w+)\}[ ]*$", re.M)


def render(template: str, **slots) -> str:
    """template with its slots filled (module docstring); every slot must be given."""
    def block(m):
        code = slots[m["name"]]
        return "\n".join(m["indent"] + line if line.strip() else "" for line in code.splitlines())
    return string.Template(_BLOCK_SLOT.sub(block, template)).substitute(slots)


def unpack(obj: str, fields) -> str:
    """Fields of a state object as locals. Numba (0.68, issues 5872/7135) loses writes made through a
    namedtuple's attribute inside a parallel loop; locals are safe everywhere."""
    return "".join(f"{name} = {obj}.{name}\n" for name in fields)
