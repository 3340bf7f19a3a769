"""A hint to the memory system from compiled loops: fetch a row of an array into the caches ahead of its use.

The pair pass reads each partner's position by index (engine/kernels.py PAIR_FORCES). With the particles
sorted by cell in row-major order, most partners of particle i lie a plane of cells ahead of it in memory: at
a million particles that is far outside the caches, and the hardware prefetcher, which follows strides, does
not see the jump coming. `prefetch_row(a, i)` issues LLVM's `llvm.prefetch` for the first element of row i of
a: no load, no fault, no effect on any value - only on when the line arrives.
"""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def prefetch_row(typingctx, array, row):
    """Prefetch row `row` of a C-contiguous 1-D or 2-D array for reading, into every cache level: the line of
    a[row] (1-D), or the lines of a[row, 0] and a[row, -1] (2-D: a row of three doubles, 24 B, straddles two
    64 B lines at one row in four)."""
    if not (isinstance(array, types.Array) and array.ndim in (1, 2) and isinstance(row, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        shape = cgutils.unpack_tuple(builder, ary.shape, aryty.ndim)
        strides = cgutils.unpack_tuple(builder, ary.strides, aryty.ndim)
        byte_ptr = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [byte_ptr, i32, i32, i32]),
                                            "llvm.prefetch.p0")
        row = context.cast(builder, args[1], signature.args[1], types.intp)  # int32 list entries, say
        columns = [context.get_constant(types.intp, 0)]
        if aryty.ndim == 2:
            columns.append(builder.sub(shape[1], context.get_constant(types.intp, 1)))
        for column in columns:
            index = [row] + ([column] if aryty.ndim == 2 else [])
            ptr = cgutils.get_item_pointer2(context, builder, ary.data, shape, strides, aryty.layout, index,
                                            wraparound=False, boundscheck=False)
            # read (0), keep in all levels (3), data cache (1)
            builder.call(fn, [builder.bitcast(ptr, byte_ptr), i32(0), i32(3), i32(1)])
        return context.get_dummy_value()
    return types.void(array, row), codegen
