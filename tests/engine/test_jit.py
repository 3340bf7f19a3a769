"""The content keys of compiled functions (engine/jit.py): what changes the machine code changes the key, what
does not (docstrings, comments, positions, other modules) leaves it."""
from __future__ import annotations

import importlib
import sys
import textwrap

import pytest
from conftest import domain, interaction, material, model, plane

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


#: a function that takes a second or so to compile, loaded by two processes that start compiling together
SLOW = '''
from engine.jit import njit


@njit(cache=True)
def slow(n):
    total = 0.0
    for i in range(n):
        {body}
    return total
'''

RACE = '''
import sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import slow_module
go = Path(sys.argv[2])
Path(sys.argv[3]).touch()                  # ready: numba and the module imported
while not go.exists():
    time.sleep(0.001)
slow_module.slow(10)
print(slow_module.slow.stats.cache_misses.get((slow_module.slow.signatures[0]), 0),
      slow_module.slow.stats.cache_hits.get((slow_module.slow.signatures[0]), 0))
'''


def test_two_processes_compile_a_function_once(tmp_path):
    """Two engines reaching a new function at the same moment: one compiles it, the other waits for the lock
    and loads the machine code the first saved (without the lock both compile)."""
    import os
    import subprocess
    import time

    # enough independent branches that compiling takes about a second
    body = "\n        ".join(f"if i % {k + 2} == 0:\n            total += {k}.5 * i / (i + {k + 1})"
                             for k in range(120))
    (tmp_path / "slow_module.py").write_text(SLOW.format(body=body))
    (tmp_path / "race.py").write_text(RACE)
    env = dict(os.environ, DEM_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(jit.Path(jit.__file__).parent.parent), os.environ.get("PYTHONPATH", "")]))
    go = tmp_path / "go"
    procs = [subprocess.Popen([sys.executable, str(tmp_path / "race.py"), str(tmp_path), str(go),
                               str(tmp_path / f"ready{k}")], env=env, stdout=subprocess.PIPE, text=True)
             for k in range(2)]
    deadline = time.monotonic() + 120
    while not all((tmp_path / f"ready{k}").exists() for k in range(2)):
        assert time.monotonic() < deadline and all(p.poll() is None for p in procs), "the processes did not start"
        time.sleep(0.01)
    go.touch()
    results = []
    for p in procs:
        out, _ = p.communicate(timeout=300)
        assert p.returncode == 0
        results.append(tuple(int(v) for v in out.split()))
    # (misses, hits) of each process: one compiled, the other loaded
    assert sorted(results) == [(0, 1), (1, 0)]


ARRAYS = '''
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from engine.jit import njit


@njit(cache=True)
def ramp(n, step):
    out = np.empty(n)            # allocated by Numba's runtime (NRT)
    for i in range(n):
        out[i] = i * step
    return out


values = ramp(5, 0.5)
print(values.tolist(), ramp.stats.cache_hits.get(ramp.signatures[0], 0), "numba.np.arraymath" in sys.modules)
'''


def test_machine_code_loads_without_the_compilers_registries(tmp_path):
    """A warm start loads machine code without importing Numba's modules of implementations (about a second
    of each engine start): the function loaded from the cache allocates and returns its array all the same."""
    import os
    import subprocess

    (tmp_path / "arrays.py").write_text(ARRAYS)
    env = dict(os.environ, DEM_CACHE_DIR=str(tmp_path / "cache"))
    engine_root = str(jit.Path(jit.__file__).parent.parent)
    runs = [subprocess.run([sys.executable, str(tmp_path / "arrays.py"), engine_root], env=env, capture_output=True,
                           text=True, check=True).stdout.split("]") for _ in range(2)]
    assert runs[0][0] == runs[1][0] == "[0.0, 0.5, 1.0, 1.5, 2.0"
    assert runs[0][1].split() == ["0", "True"]    # compiled: the compiler's registries are loaded
    assert runs[1][1].split() == ["1", "False"]   # loaded: they are not


@pytest.mark.slow
def test_a_scene_compiles_each_pass_once_and_shares_what_two_combinations_have_alike(tmp_path):
    """A run of a scene of spheres, then a plane added and a second run (another combination in the same
    process): the setup is not compiled, each pass has one signature (the step loop passes its flags as
    run-time booleans, as the Python setup does), and the pair pass - alike in both combinations - is one
    compiled function, which another process running the second combination alone loads (Numba imports the
    module it was compiled in). The bytes of the results: benchmarks/engine_identical.py."""
    import json
    import os
    import subprocess


    scene = [domain(), material(), interaction(mu=0.3), model(),
             {"command": "create", "object": "lattice", "type": 1, "radius": 0.01, "spacing": 0.025,
              "region": {"shape": "box", "lo": [-0.1, -0.1, -0.1], "hi": [0.1, 0.1, 0.1]}},
             {"command": "set", "property": "timestep", "value": 1e-5},
             {"command": "run", "steps": 20},
             plane("floor", "z", -0.2),
             {"command": "run", "steps": 20}]
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    cache = tmp_path / "cache"
    env = dict(os.environ, DEM_CACHE_DIR=str(cache),
               PYTHONPATH=os.pathsep.join([str(jit.Path(jit.__file__).parent.parent), os.environ.get("PYTHONPATH", "")]))
    subprocess.run([sys.executable, "-m", "engine", "-in", "scene.json"], cwd=tmp_path, env=env, check=True,
                   capture_output=True)
    modules = sorted(cache.glob("dem_kernel_*.py"))
    assert len(modules) == 2                                   # two combinations
    compiled = sorted(p.name for p in (cache / "jit").glob("*.nbc"))

    def of(name):
        return [p for p in compiled if p.startswith(name + "-")]
    assert not of("setup")
    assert len(of("pair_forces")) == 1                         # one function for both combinations
    assert len(of("particle_pass")) == 2                       # one per combination, one signature each
    assert len(of("run_steps")) == 2
    assert len(of("drift_pass")) == 1                          # alike too: no gravity in either
    # a new process running the second combination alone loads every function, the pair pass from the code
    # compiled in the first combination's module
    (tmp_path / "walled.json").write_text(json.dumps(scene[:6] + scene[7:]))
    subprocess.run([sys.executable, "-m", "engine", "-in", "walled.json"], cwd=tmp_path, env=env, check=True,
                   capture_output=True)
    assert sorted(p.name for p in (cache / "jit").glob("*.nbc")) == compiled


SHAPES = '''
from collections import namedtuple
Pair = namedtuple("Pair", ["a", "b"])
{extra}
'''
USE = '''
import sys
sys.path.insert(0, sys.argv[1])
sys.path.insert(0, sys.argv[2])
import shapes
from engine.jit import njit


@njit(cache=True)
def total(p):
    return p.a + p.b


if hasattr(shapes, "Extra"):
    print(total(shapes.Extra(1.0, 2.0)))
print(total(shapes.Pair(3.0, 4.0)))
'''


def test_a_cache_index_naming_a_class_this_build_lacks_is_compiled_anew(tmp_path):
    """A function's cache index holds the signatures every build compiled it for; a namedtuple argument is
    named there by module and class. A later build without that class (another commit of the engine, say)
    compiles the function again instead of failing to read the index."""
    import os
    import subprocess

    (tmp_path / "use.py").write_text(USE)
    env = dict(os.environ, DEM_CACHE_DIR=str(tmp_path / "cache"))
    engine_root = str(jit.Path(jit.__file__).parent.parent)
    outputs = []
    for extra in ('Extra = namedtuple("Extra", ["a", "b"])', "", ""):
        (tmp_path / "shapes.py").write_text(SHAPES.format(extra=extra))
        done = subprocess.run([sys.executable, str(tmp_path / "use.py"), engine_root, str(tmp_path)], env=env,
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-2000:]
        outputs.append(done.stdout.split())
    assert outputs == [["3.0", "7.0"], ["7.0"], ["7.0"]]


PARALLEL_CALLEE = '''
import sys
import numpy as np
from numba import prange
sys.path.insert(0, sys.argv[1])
from engine.jit import njit


@njit(cache=True, parallel=True)
def total(x):
    s = 0.0
    for i in prange(x.shape[0]):
        s += x[i]
    return s


@njit(cache=True)
def total_plus_one(x):
    return total(x) + 1.0


function = total if sys.argv[2] == "total" else total_plus_one
print(function(np.ones(1000)), function.stats.cache_hits.get(function.signatures[0], 0))
'''


def test_a_function_compiled_over_a_cached_parallel_callee_loads_first_in_a_process(tmp_path):
    """The parallel callee compiled and cached first; then its caller compiled while the callee is loaded from
    the cache (a commit that changes the caller alone): Numba marks only code whose parallel loop it compiled
    itself as needing the threading layer. Loaded first in a new process, the caller used to die of a
    segmentation fault in its loop (engine/jit.py starts the layer before loading)."""
    import os
    import subprocess

    (tmp_path / "parallel.py").write_text(PARALLEL_CALLEE)
    env = dict(os.environ, DEM_CACHE_DIR=str(tmp_path / "cache"))
    engine_root = str(jit.Path(jit.__file__).parent.parent)
    outputs = []
    for function in ("total", "total_plus_one", "total_plus_one"):
        done = subprocess.run([sys.executable, str(tmp_path / "parallel.py"), engine_root, function], env=env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, f"{function}: exit {done.returncode} {done.stderr[-2000:]}"
        outputs.append(done.stdout.split())
    assert outputs == [["1000.0", "0"], ["1001.0", "0"], ["1001.0", "1"]]   # compiled, compiled, loaded
