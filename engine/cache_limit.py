"""The size of the compiled-code cache (``$DEM_CACHE_DIR``, engine/jit.py): least recently used entries go
once it passes a limit.

Machine code keyed by content (engine/jit.py) never goes stale: the code of a revision stays valid as long as
its functions exist in some build, so nothing ever replaces it and the cache grows by every revision that is
run - about 64 MB for the whole test case collection at one revision. A limit keeps it bounded the way ccache
does: ``DEM_CACHE_LIMIT`` (bytes, or a number with K, M or G, powers of 1024; ``0`` = no limit; default 1G, about
sixteen revisions of the whole collection, so a bisect over eight engine commits keeps all of its code).

An entry is what is kept or removed as one:

- a compiled function's machine code, ``jit/<name>-<key>.nbi`` (Numba's index) with its ``.nbc`` files; last
  used = the index's modification time, which loading the code refreshes (`touch`);
- a generated kernel module, ``dem_kernel_<hash>.py`` (engine/kernels.py refreshes its time when a run uses
  it; machine code compiled in a removed module is compiled again, engine/jit.py);
- any other file under the folder (Python's byte code of the kernel modules, machine code of older engine
  versions in ``__pycache__``), by its own modification time.

A run that compiled something (`note_write`) checks the size at its end (`after_run`) and, if it is above the
limit, removes the least recently used entries until the cache is at `TARGET` of the limit (so that the next
run does not prune again) - never an entry used within the last `KEEP_RECENT` seconds, which a run going on
may be loading, and under a lock (``prune.lock``) so that two runs do not prune at once. Compile locks
(``jit/<key>.lock``, empty files) older than a day go too. ``dem -cache`` shows the cache,
``dem -cache-prune SIZE`` prunes it now.
"""
from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from filelock import FileLock, Timeout

from .errors import InputError

#: bytes when DEM_CACHE_LIMIT is not set (1 GiB)
DEFAULT_LIMIT = 1 << 30
#: a prune stops at this fraction of the limit
TARGET = 0.8
#: seconds: entries used more recently are never removed (a run going on may be loading them)
KEEP_RECENT = 3600.0
#: seconds: compile locks older than this are removed (a compilation holds its lock for minutes at most)
LOCK_AGE = 86400.0

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_written = False


def cache_dir() -> Path:
    """$DEM_CACHE_DIR, else ~/.cache/dem-engine (generated kernels and the compiled functions' machine code)."""
    env = os.environ.get("DEM_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "dem-engine"


def parse_size(text: str) -> int:
    """Bytes of a size such as 1073741824, 500M, 1.5G (K, M, G, T: powers of 1024; an optional B); ValueError."""
    match = re.fullmatch(r"\s*(\d+(?:\.\d*)?)\s*([KMGT]?)(?:i?B)?\s*", text, re.IGNORECASE)
    if match is None:
        raise ValueError(f"'{text}' is not a size (bytes, or a number with K, M, G or T)")
    return int(float(match.group(1)) * _UNITS[match.group(2).upper()])


def limit() -> int:
    """The limit in bytes from DEM_CACHE_LIMIT (0 = none); InputError naming the variable if it is not a size."""
    text = os.environ.get("DEM_CACHE_LIMIT")
    if text is None or text.strip() == "":
        return DEFAULT_LIMIT
    try:
        return parse_size(text)
    except ValueError as exc:
        raise InputError(f"environment variable DEM_CACHE_LIMIT: {exc}; 0 = no limit") from None


@dataclass
class Entry:
    """Files kept or removed together; last_use in seconds since the epoch, size in bytes."""
    name: str
    last_use: float = 0.0
    size: int = 0
    paths: list = field(default_factory=list)


def _entry_name(folder: Path, path: Path) -> str:
    relative = path.relative_to(folder)
    if relative.parts[0] == "jit" and len(relative.parts) == 2:
        # name-key.nbi and name-key.<n>.nbc: one function's machine code (engine/jit.py names them)
        match = re.fullmatch(r"(.+?)(?:\.\d+\.nbc|\.nbi)", path.name)
        if match:
            return "jit/" + match.group(1)
    return str(relative)


def entries(folder: Path) -> list:
    """The cache's entries (module docstring), compile locks and prune.lock left out."""
    found: dict = {}
    for root, _dirs, files in os.walk(folder):
        for name in files:
            path = Path(root) / name
            if name.endswith(".lock"):
                continue
            try:
                st = path.stat()
            except FileNotFoundError:  # removed by another process meanwhile
                continue
            key = _entry_name(folder, path)
            entry = found.setdefault(key, Entry(key))
            entry.size += st.st_size
            # an index's time is its function's last use (loading refreshes it); its .nbc files keep the time
            # of their writing
            if path.suffix != ".nbc" or key == str(path.relative_to(folder)):
                entry.last_use = max(entry.last_use, st.st_mtime)
            entry.paths.append(path)
    for entry in found.values():  # .nbc files whose index is gone: by their own time
        if entry.last_use == 0.0:
            entry.last_use = max(p.stat().st_mtime for p in entry.paths if p.exists()) if entry.paths else 0.0
    return list(found.values())


def prune(folder: Path, max_bytes: int, keep_recent: float = KEEP_RECENT, now: float | None = None) -> tuple:
    """Removes least recently used entries while the cache holds more than max_bytes, down to TARGET of it,
    never one used within keep_recent seconds; compile locks older than LOCK_AGE. Returns (entries removed,
    bytes freed, bytes left)."""
    now = time.time() if now is None else now
    found = entries(folder)
    total = sum(e.size for e in found)
    removed = freed = 0
    if total > max_bytes:
        goal = int(max_bytes * TARGET)
        for entry in sorted(found, key=lambda e: e.last_use):
            if total - freed <= goal or entry.last_use > now - keep_recent:
                break
            for path in entry.paths:
                try:
                    path.unlink()
                except FileNotFoundError:
                    pass
            removed += 1
            freed += entry.size
    jit = folder / "jit"
    if jit.is_dir():
        for path in jit.glob("*.lock"):
            try:
                if path.stat().st_mtime < now - LOCK_AGE:
                    path.unlink()
            except FileNotFoundError:
                pass
    return removed, freed, total - freed


def touch(path) -> None:
    """Marks an entry's file as used now (its modification time; access times are often not kept)."""
    try:
        os.utime(path)
    except OSError:  # removed by a prune meanwhile, or a read-only cache: nothing to keep fresh
        pass


def note_write() -> None:
    """This process wrote machine code into the cache: after_run checks the limit."""
    global _written
    _written = True


def after_run(folder: Path) -> tuple | None:
    """At the end of a run that compiled something: prune to the limit if the cache is above it (skipped while
    another process prunes). Returns prune's figures, or None when nothing was checked."""
    global _written
    if not _written:
        return None
    _written = False
    max_bytes = limit()
    if max_bytes <= 0 or not folder.is_dir():
        return None
    try:
        with FileLock(str(folder / "prune.lock"), timeout=0):
            return prune(folder, max_bytes)
    except Timeout:
        return None


def summary(folder: Path) -> str:
    """Lines for `dem -cache`: the folder, its size and entries, the limit."""
    found = entries(folder) if folder.is_dir() else []
    total = sum(e.size for e in found)
    code = [e for e in found if e.name.startswith("jit/")]
    modules = [e for e in found if re.fullmatch(r"dem_kernel_[0-9a-f]+\.py", e.name)]
    max_bytes = limit()
    lines = [f"cache folder: {folder} (DEM_CACHE_DIR)",
             f"size: {total / 2**20:.1f} MiB in {len(found)} entries: machine code of {len(code)} compiled functions "
             f"{sum(e.size for e in code) / 2**20:.1f} MiB, {len(modules)} generated kernel modules, "
             f"{len(found) - len(code) - len(modules)} other files",
             "limit: " + (f"{max_bytes / 2**20:.0f} MiB" if max_bytes > 0 else "none") + " (DEM_CACHE_LIMIT; a run "
             f"that compiled prunes the least recently used entries down to {TARGET:.0%} of it)"]
    if found:
        oldest = min(e.last_use for e in found)
        lines.append(f"least recently used entry: {time.strftime('%Y-%m-%d %H:%M', time.localtime(oldest))}")
    return "\n".join(lines)
