"""How much memory a particle creation needs, estimated before anything is allocated.

A lattice or random packing of 1e12 spheres would otherwise die in numpy with a MemoryError (or be killed by
the kernel's OOM killer halfway through); the engine refuses it up front as bad input, naming the command
and the field that asked for it.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

#: neighbor indices are int32 (engine/neighbor.py): no more particles than that can be addressed
MAX_PARTICLES = 2 ** 31 - 1

# Bytes of temporary arrays per item while a create runs (float64 = 8 bytes), read off the code in scene.py:
#: lattice_points, per site of the bounding-box grid: meshgrid (3 x 8), the stacked grid (24), the clearance
#: margin (8), the comparison masks (about 10 booleans) and the selected points (24)
LATTICE_SITE_BYTES = 96
#: random_packing, per sphere: radii (8, twice for a radius range), _place_spheres' px, pr, nxt, out
#: (24 + 8 + 8 + 24) and cell heads (at most 8 cells per sphere, 8 bytes each); candidates are drawn in batches
#: of scene.CANDIDATE_BATCH (24 bytes each), whatever max_attempts is
PACKING_SPHERE_BYTES = 16 + 64 + 64
PACKING_ATTEMPT_BYTES = 24
PACKING_BATCH = 1 << 16
#: _add_particles: concatenating one state array at a time holds old + new copies of it (the widest is
#: 3 x 8 bytes); positions, radii, masses and tiled velocities of the new particles (24 + 8 + 8 + 48)
ADD_OLD_BYTES = 24
ADD_NEW_BYTES = 24 + 88


def available_bytes() -> int | None:
    """Memory this process may still use, B: /proc/meminfo MemAvailable, lowered to the room left under a
    cgroup v2 memory limit; os.sysconf's free pages where /proc is missing; None when nothing tells."""
    found = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                found = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError, IndexError):
        found = None
    if found is None:
        try:
            found = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            found = None
    limit = _cgroup_room()
    if limit is not None:
        found = limit if found is None else min(found, limit)
    return found


def _cgroup_room() -> int | None:
    """memory.max - memory.current of this process's cgroup (v2), or None without a limit."""
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
        rel = next(line.split("::", 1)[1] for line in lines if line.startswith("0::"))
        folder = Path("/sys/fs/cgroup") / rel.lstrip("/")
        limit = (folder / "memory.max").read_text().strip()
        if limit == "max":
            return None
        return max(0, int(limit) - int((folder / "memory.current").read_text().strip()))
    except (OSError, ValueError, StopIteration):
        return None


def human(nbytes: float) -> str:
    """A byte count for a message: 7.3 TB, 512 MB."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if nbytes < 1000 or unit == "PB":
            return f"{nbytes:.3g} {unit}"
        nbytes /= 1000
    return f"{nbytes:.3g} PB"


def lattice_sites(lo, hi, spacing: float) -> int:
    """Sites of the simple cubic grid lattice_points builds over a region's bounding box (exact integer)."""
    count = 1
    for a in range(3):
        per_axis = (hi[a] - lo[a]) / spacing
        if not math.isfinite(per_axis):  # a spacing of 1e-320 m: more sites than a double counts
            return 2 ** 1000
        count *= max(0, int(math.floor(per_axis)))
    return count


def creation_bytes(new_particles: int, existing: int, particle_bytes: int, grid_sites: int = 0,
                   attempts: int = 0) -> int:
    """Bytes a create needs on top of what the process holds now: the new particles' state, the copies made
    while appending them, and the create's own temporaries (lattice grid sites, random packing candidates)."""
    need = new_particles * (particle_bytes + ADD_NEW_BYTES) + (existing + new_particles) * ADD_OLD_BYTES
    need += grid_sites * LATTICE_SITE_BYTES
    if attempts:
        need += new_particles * PACKING_SPHERE_BYTES + min(attempts * new_particles, PACKING_BATCH) * PACKING_ATTEMPT_BYTES
    return need
