"""The prefetch hint of the pair pass (engine/prefetch.py): it reaches the machine code and changes no value."""
import re

import numpy as np
import pytest
from numba import njit

from engine.prefetch import prefetch_row


@njit
def _gathered_sum(a, index, ahead):
    total = 0.0
    for k in range(index.shape[0]):
        if ahead:
            prefetch_row(a, index[min(k + 8, index.shape[0] - 1)])
        row = index[k]
        if a.ndim == 2:
            total += a[row, 0] + a[row, a.shape[1] - 1]
        else:
            total += a[row]
    return total


@njit
def _prefetch_one(a, row):
    prefetch_row(a, row)


@pytest.mark.parametrize("shape", [(5000,), (5000, 3)])
@pytest.mark.parametrize("index_type", [np.int64, np.int32])  # the neighbor list's entries are int32
def test_prefetch_changes_no_value_and_reaches_the_machine_code(shape, index_type):
    rng = np.random.default_rng(1)
    a = rng.random(shape)
    index = rng.integers(0, shape[0], 20000).astype(index_type)
    assert _gathered_sum(a, index, True) == _gathered_sum(a, index, False)
    ir = _prefetch_one.inspect_llvm()[(_prefetch_one.typeof_pyval(a), _prefetch_one.typeof_pyval(index[3]))] if \
        _prefetch_one(a, index[3]) is None else ""
    # read, all cache levels, data: the line of a 1-D array's row; a 2-D row's first and last column
    calls = re.findall(r"call void @llvm\.prefetch\.p0\(ptr [^,]+, i32 0, i32 3, i32 1\)", ir)
    assert len(calls) == (2 if len(shape) == 2 else 1)


def test_the_generated_pair_pass_prefetches_the_partners_it_gathers():
    from engine.kernels import Combination, generate_source

    source = generate_source(Combination(normal="hertz", tangential="history"))
    pair = source[source.index("def pair_forces"):source.index("def particle_pass")]
    assert "prefetch_row(x, ahead)" in pair and "prefetch_row(radius, ahead)" in pair
    gather = pair[pair.index("ahead = cj["):]
    gather = gather[:gather.index("for cq in range(m):")]
    # every array the gather sweep reads at the partner j, and no other
    read = set(re.findall(r"\b(\w+)\[j\b", gather))
    fetched = set(re.findall(r"prefetch_row\((\w+), ahead\)", gather))
    assert read and fetched == read
