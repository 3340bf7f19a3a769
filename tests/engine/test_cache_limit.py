"""The compiled-code cache's limit (engine/cache_limit.py): least recently used entries go, recent ones stay,
loading machine code marks it used, a run that compiled prunes, `dem -cache` / `dem -cache-prune`."""
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from engine import cache_limit
from engine.errors import InputError

ENGINE_ROOT = str(Path(cache_limit.__file__).parent.parent)
HOUR = 3600.0


def _file(path: Path, size: int, age: float, now: float) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0" * size)
    os.utime(path, (now - age, now - age))
    return path


@pytest.mark.parametrize("text, size", [("0", 0), ("4096", 4096), ("500M", 500 << 20), ("1.5G", 3 << 29),
                                        ("2k", 2048), ("1GiB", 1 << 30), (" 3 MB ", 3 << 20)])
def test_sizes(text, size):
    assert cache_limit.parse_size(text) == size


@pytest.mark.parametrize("text", ["", "5X", "-1G", "G", "1.2.3M"])
def test_bad_sizes_and_a_bad_limit_name_the_variable(text, monkeypatch):
    with pytest.raises(ValueError, match="is not a size"):
        cache_limit.parse_size(text)
    if text.strip():
        monkeypatch.setenv("DEM_CACHE_LIMIT", text)
        with pytest.raises(InputError, match="environment variable DEM_CACHE_LIMIT: .* 0 = no limit"):
            cache_limit.limit()


def test_least_recently_used_entries_go_first_down_to_the_target(tmp_path):
    now = time.time()
    jit = tmp_path / "jit"
    # three functions' machine code (index + data files, the index's time is the last use), a generated kernel
    # module, byte code of an older engine; 100 kB each entry
    old = [_file(jit / "pair_forces-aaaaaaaaaaaaaaaaaaaaaaaa.nbi", 10_000, 50 * HOUR, now),
           _file(jit / "pair_forces-aaaaaaaaaaaaaaaaaaaaaaaa.1.nbc", 90_000, 2 * HOUR, now)]  # its data newer
    older = [_file(tmp_path / "__pycache__" / "dem_kernel_1.run_steps-7.py311.1.nbc", 100_000, 60 * HOUR, now)]
    middle = [_file(tmp_path / "dem_kernel_0123456789abcdef0123.py", 100_000, 40 * HOUR, now)]
    newer = [_file(jit / "run_steps-bbbbbbbbbbbbbbbbbbbbbbbb.nbi", 50_000, 10 * HOUR, now),
             _file(jit / "run_steps-bbbbbbbbbbbbbbbbbbbbbbbb.1.nbc", 25_000, 30 * HOUR, now),
             _file(jit / "run_steps-bbbbbbbbbbbbbbbbbbbbbbbb.2.nbc", 25_000, 30 * HOUR, now)]
    recent = [_file(jit / "setup.locals.inner-cccccccccccccccccccccccc.nbi", 100_000, 0.5 * HOUR, now)]
    stale_lock = _file(jit / ("d" * 64 + ".lock"), 0, 30 * HOUR, now)
    fresh_lock = _file(jit / ("e" * 64 + ".lock"), 0, 2 * HOUR, now)

    found = {e.name: e for e in cache_limit.entries(tmp_path)}
    assert found["jit/run_steps-bbbbbbbbbbbbbbbbbbbbbbbb"].size == 100_000
    assert found["jit/pair_forces-aaaaaaaaaaaaaaaaaaaaaaaa"].last_use == pytest.approx(now - 50 * HOUR)
    assert "jit/setup.locals.inner-cccccccccccccccccccccccc" in found and len(found) == 5

    # 500 kB held, limit 300 kB: down to 240 kB - the two least recently used entries (the byte code and the
    # function used 50 h ago, though its data file was written 2 h ago) and the kernel module go
    removed, freed, left = cache_limit.prune(tmp_path, 300_000, now=now)
    assert (removed, freed, left) == (3, 300_000, 200_000)
    assert not any(p.exists() for p in old + older + middle)
    assert all(p.exists() for p in newer + recent)
    assert not stale_lock.exists() and fresh_lock.exists()

    # above the limit, but what was used within the hour stays (a run going on may be loading it)
    removed, freed, left = cache_limit.prune(tmp_path, 0, now=now)
    assert (removed, left) == (1, 100_000)
    assert all(p.exists() for p in recent) and not any(p.exists() for p in newer)


def test_below_the_limit_nothing_goes(tmp_path):
    now = time.time()
    kept = _file(tmp_path / "jit" / "f-ffffffffffffffffffffffff.nbi", 1000, 100 * HOUR, now)
    assert cache_limit.prune(tmp_path, 1000, now=now) == (0, 0, 1000)
    assert kept.exists()


PROGRAM = '''
import sys
sys.path.insert(0, sys.argv[1])
from engine import cache_limit
from engine.jit import njit


@njit(cache=True)
def {name}(n):
    total = 0
    for i in range(n):
        total += i
    return total


print({name}(4), {name}.stats.cache_hits.get({name}.signatures[0], 0), cache_limit.after_run(cache_limit.cache_dir()))
'''


def test_loading_marks_code_used_and_a_compiling_run_prunes_to_the_limit(tmp_path):
    """Real compiled functions in a cache of their own: loading refreshes the index's time; a process that
    compiled prunes (DEM_CACHE_LIMIT), the least recently used function first, one that only loaded does not."""
    cache = tmp_path / "cache"
    env = dict(os.environ, DEM_CACHE_DIR=str(cache), DEM_CACHE_LIMIT="0")

    def run(name, **more):
        (tmp_path / f"{name}.py").write_text(PROGRAM.format(name=name))
        return subprocess.run([sys.executable, str(tmp_path / f"{name}.py"), ENGINE_ROOT], env=dict(env, **more),
                              capture_output=True, text=True, check=True).stdout.strip().split(maxsplit=2)

    assert run("first") == ["6", "0", "None"]  # compiled; no limit
    index = next((cache / "jit").glob("first-*.nbi"))
    day_ago = time.time() - 24 * HOUR
    os.utime(index, (day_ago, day_ago))
    assert run("first", DEM_CACHE_LIMIT="1") == ["6", "1", "None"]  # loaded: no prune, but used now
    assert index.stat().st_mtime > day_ago + 23 * HOUR

    os.utime(index, (day_ago, day_ago))
    out = run("second", DEM_CACHE_LIMIT="1")  # compiles: the cache is above 1 byte, "first" goes
    assert out[:2] == ["6", "0"] and out[2].startswith("(1, ")
    assert not list((cache / "jit").glob("first-*")) and list((cache / "jit").glob("second-*.nbi"))


def test_dem_cache_shows_and_prunes(tmp_path):
    now = time.time()
    cache = tmp_path / "cache"
    _file(cache / "jit" / "f-ffffffffffffffffffffffff.nbi", 3 << 20, 5 * HOUR, now)
    _file(cache / "dem_kernel_0123456789abcdef0123.py", 1 << 20, 2 * HOUR, now)
    env = dict(os.environ, DEM_CACHE_DIR=str(cache), PYTHONPATH=ENGINE_ROOT)
    shown = subprocess.run([sys.executable, "-m", "engine", "-cache"], env=env, capture_output=True, text=True)
    assert shown.returncode == 0
    assert "size: 4.0 MiB in 2 entries: machine code of 1 compiled functions 3.0 MiB, 1 generated kernel" in shown.stdout
    pruned = subprocess.run([sys.executable, "-m", "engine", "-cache-prune", "2M"], env=env, capture_output=True,
                            text=True)
    assert pruned.returncode == 0 and pruned.stdout.startswith("removed 1 entries (3.0 MiB)")
    bad = subprocess.run([sys.executable, "-m", "engine", "-cache-prune", "lots"], env=env, capture_output=True,
                         text=True)
    assert bad.returncode == 2 and bad.stderr.strip() == \
        "ERROR: -cache-prune: 'lots' is not a size (bytes, or a number with K, M, G or T)"
    run = subprocess.run([sys.executable, "-m", "engine", "-in", "none.json"], cwd=tmp_path,
                         env=dict(env, DEM_CACHE_LIMIT="big"), capture_output=True, text=True)
    assert run.returncode == 2 and "environment variable DEM_CACHE_LIMIT: 'big' is not a size" in run.stderr
