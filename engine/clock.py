"""A wall clock readable from compiled code (for the pair/neigh/modify timing breakdown)."""
import time

from numba import njit, objmode


@njit(cache=True)
def now():
    """time.perf_counter() in s; an object-mode call costs well under a microsecond per read."""
    with objmode(t="float64"):
        t = time.perf_counter()
    return t
