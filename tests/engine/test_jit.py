"""The content keys of compiled functions (engine/jit.py): what changes the machine code changes the key, what
does not (docstrings, comments, positions, other modules) leaves it."""
from __future__ import annotations

import importlib
import sys
import textwrap

import pytest

from engine import jit

CALLEE = '''
"""A module of compiled helpers."""
from engine.jit import njit

SCALE = 2.0


@njit(cache=True, error_model="numpy")
def twice(x):
    """x times SCALE."""
    return SCALE * x
'''

CALLER = '''
"""A module calling the helper."""
from engine.jit import njit

from {prefix}_callee import twice


@njit(cache=True)
def caller(x):
    """twice x, plus one."""
    y = twice(x)  # the helper
    return y + 1.0
'''


def _key(tmp_path, prefix: str, callee: str = CALLEE, caller: str = CALLER) -> str:
    folder = tmp_path / prefix
    folder.mkdir()
    (folder / f"{prefix}_callee.py").write_text(textwrap.dedent(callee))
    (folder / f"{prefix}_caller.py").write_text(textwrap.dedent(caller.format(prefix=prefix)))
    sys.path.insert(0, str(folder))
    try:
        module = importlib.import_module(f"{prefix}_caller")
        return jit.content_key(module.caller)
    finally:
        sys.path.remove(str(folder))


def test_docstrings_comments_and_positions_leave_the_key(tmp_path):
    base = _key(tmp_path, "k_base")
    moved = _key(tmp_path, "k_moved",
                 callee=CALLEE.replace('"""x times SCALE."""', '"""Return x multiplied by SCALE (m)."""')
                 .replace("SCALE = 2.0", "# a comment\n\nSCALE = 2.0  # why two"),
                 caller="\n\n# more lines above\n" + CALLER.replace('"""twice x, plus one."""', '"""Changed."""')
                 .replace("# the helper", "# the helper, doubled"))
    assert moved == base


@pytest.mark.parametrize("change", [
    ("CALLEE", "return SCALE * x", "return x * SCALE"),                          # the callee's body
    ("CALLEE", "SCALE = 2.0", "SCALE = 3.0"),                                    # a constant the callee reads
    ("CALLEE", 'error_model="numpy"', 'error_model="python"'),                  # the callee's compile options
    ("CALLER", "return y + 1.0", "return y + 2.0"),                              # the function itself
])
def test_what_changes_the_code_changes_the_key(tmp_path, change):
    which, old, new = change
    base = _key(tmp_path, "k_base")
    sources = {"CALLEE": CALLEE, "CALLER": CALLER}
    assert old in sources[which]
    sources[which] = sources[which].replace(old, new)
    assert _key(tmp_path, "k_changed", callee=sources["CALLEE"], caller=sources["CALLER"]) != base


def test_engine_kernel_keys_follow_their_callees():
    """The step kernel's key depends on the neighbor rebuild it calls, the pair loop's does not."""
    from engine import neighbor
    from engine.kernels import Combination, build_kernel

    kernel = build_kernel(Combination(planes=True, gravity=True))
    step_key, pair_key = jit.content_key(kernel.run_steps), jit.content_key(kernel.pair_forces)
    rebuild_key = jit.content_key(neighbor.rebuild)
    old = neighbor.MAX_CELLS_PER_PARTICLE
    saved = dict(jit._keys)
    try:
        neighbor.MAX_CELLS_PER_PARTICLE = old + 1   # a constant rebuild reads
        jit._keys.clear()
        assert jit.content_key(neighbor.rebuild) != rebuild_key
        assert jit.content_key(kernel.run_steps) != step_key
        assert jit.content_key(kernel.pair_forces) == pair_key
    finally:
        neighbor.MAX_CELLS_PER_PARTICLE = old
        jit._keys.clear()
        jit._keys.update(saved)
