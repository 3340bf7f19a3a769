"""A wall clock readable from compiled code (for the pair/neigh/modify timing breakdown).

`now()` calls the C library's clock_gettime(CLOCK_MONOTONIC) directly from the machine code (an LLVM call
resolved by name, so the disk cache keeps working): no return into the Python interpreter inside the step
loop, a few tens of nanoseconds per read.
"""
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from .jit import njit

CLOCK_MONOTONIC = 1  # Linux


@intrinsic
def _monotonic_ns(typingctx):
    def codegen(context, builder, signature, args):
        i32, i64 = ir.IntType(32), ir.IntType(64)
        timespec = ir.LiteralStructType([i64, i64])  # struct timespec {time_t tv_sec; long tv_nsec;} (LP64)
        ts = cgutils.alloca_once(builder, timespec)
        clock_gettime = cgutils.get_or_insert_function(builder.module, ir.FunctionType(i32, [i32, timespec.as_pointer()]),
                                                       "clock_gettime")
        builder.call(clock_gettime, [ir.Constant(i32, CLOCK_MONOTONIC), ts])
        seconds = builder.load(cgutils.gep_inbounds(builder, ts, 0, 0))
        nanoseconds = builder.load(cgutils.gep_inbounds(builder, ts, 0, 1))
        return builder.add(builder.mul(seconds, ir.Constant(i64, 1_000_000_000)), nanoseconds)
    return types.int64(), codegen


@njit(cache=True)
def now():
    """Monotonic time in s (the clock of time.monotonic)."""
    return _monotonic_ns() * 1e-9
