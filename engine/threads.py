"""How many threads the compiled loops use: ``-threads N``, else NUMBA_NUM_THREADS, else every core.

Results do not depend on the count: every parallel loop writes only its own particles' rows and adds every
sum in the serial order (see engine/neighbor.py and engine/kernels.py), so 1 and 16 threads give the same
bytes. Small scenes run on one
thread: waking other threads costs microseconds per loop, more than the loop itself below a few thousand
particles. Threads only pay where cores are free: on a machine whose cores are all busy (other programs, or
the harness running several engines at once) every parallel loop waits for its slowest thread, and one thread
per engine is faster.

Threading layer: OpenMP first, then Numba's workqueue, TBB last (with TBB 2021/2022 each parallel region keeps
a few kB that are never freed, measured here: a long run would grow without bound).
"""
from __future__ import annotations

import os
import sys

#: below this many particles the loops run on one thread (environment variable DEM_SERIAL_BELOW overrides it;
#: tests set 0 to run tiny scenes on every thread)
SERIAL_BELOW = 2000
LAYER_PRIORITY = "omp workqueue tbb"


def configure(requested: int | None):
    """Before Numba is imported: the thread pool size and the threading layer order (an explicit
    NUMBA_THREADING_LAYER of the user wins)."""
    if "numba" in sys.modules:  # too late (the engine runs inside another program): `use` caps at the pool
        return
    if requested is not None:
        os.environ["NUMBA_NUM_THREADS"] = str(requested)
    os.environ.setdefault("NUMBA_THREADING_LAYER_PRIORITY", LAYER_PRIORITY)
    # Numba warns about parallel functions whose loops it parallelised only through prange; the contract is one
    # ERROR line on stderr and nothing else
    os.environ.setdefault("NUMBA_DISABLE_PERFORMANCE_WARNINGS", "1")


def pool_size() -> int:
    """Threads Numba can use in this process (NUMBA_NUM_THREADS, fixed when Numba was imported)."""
    # numba is imported on use: it reads NUMBA_NUM_THREADS once, so not before configure() has set it
    from numba import config

    return int(config.NUMBA_NUM_THREADS)


def use(particles: int, wanted: int) -> int:
    """Set the threads of the next compiled calls for a scene of `particles`; returns the count used."""
    import numba  # on use, after configure() (see pool_size)

    try:
        below = int(os.environ.get("DEM_SERIAL_BELOW", SERIAL_BELOW))
    except ValueError:
        below = SERIAL_BELOW
    count = 1 if particles < below else max(1, min(wanted, pool_size()))
    numba.set_num_threads(count)
    # one contiguous share of equal size per thread (Numba's default schedule): OpenMP hands out the chunks of a
    # chunk size statically anyway (no load balancing), and 40 chunks of 256 of a 10,000-particle loop cost
    # about 4 us more per loop to schedule and gave one thread 5 % more particles than the other: the settling
    # scene ran 9 % faster on two threads without them (engine/README.md, "Parallel loops")
    numba.set_parallel_chunksize(0)
    return count


def layer() -> str:
    """The threading layer in use ('unknown' before the first parallel call)."""
    import numba  # on use, after configure() (see pool_size)

    try:
        return numba.threading_layer()
    except ValueError:
        return "unknown"
