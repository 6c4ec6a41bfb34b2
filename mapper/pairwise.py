"""numpy's pairwise sum of a 1-D float64 array, bit for bit, as a numba kernel.

``np.sum`` (``np.add.reduce``) of a float64 array does not add left to right: blocks of at
most 128 values are summed with eight accumulators, longer runs halved. Kernels that must
give numpy's sums bit for bit (the tilt filter's, `mapper.tilt_kernels`; z-matching's means,
`mapper.zmatch`) call `pairwise_sum`. One kernel for both: each had its own copy, and a cold
cache compiled both (about 1 s of CPU time on the Intel Xeon of ``bench/bench_cold.py``).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["block_sum", "pairwise_sum"]

_START = np.int64(0)
"""`block_sum`'s start of a whole array: a numpy scalar, as the stack's starts (a literal 0 is
a type of its own, and numba would compile `block_sum` a second time for it)."""


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def block_sum(values, start, n):
    """The pairwise sum numpy takes of ``values[start:start + n]`` for n ≤ 128.

    A plain loop below 8 values, else 8 accumulators, combined pairwise, and the rest added one
    by one.
    """
    if n < 8:
        total = 0.0
        for i in range(start, start + n):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = 8
    while i < n - n % 8:
        k = start + i
        r0 += values[k]
        r1 += values[k + 1]
        r2 += values[k + 2]
        r3 += values[k + 3]
        r4 += values[k + 4]
        r5 += values[k + 5]
        r6 += values[k + 6]
        r7 += values[k + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        total += values[start + i]
        i += 1
    return total


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def pairwise_sum(values):
    """``np.sum`` of a 1-D float64 array, bit for bit.

    numpy's pairwise sum: above 128 values the halves (the first a multiple of 8 long) summed
    and added. Done with a stack, not recursion (a recursive kernel crashed when loaded from
    numba's cache).
    """
    n = values.shape[0]
    if n <= 128:
        return block_sum(values, _START, n)
    depth = 3 * 64  # three entries per level; the halving ends within 64 levels
    starts = np.empty(depth, dtype=np.int64)
    lengths = np.empty(depth, dtype=np.int64)
    combine = np.empty(depth, dtype=np.bool_)
    partial = np.empty(depth)
    tasks = 0
    results = 0
    starts[0], lengths[0], combine[0] = 0, n, False
    tasks = 1
    while tasks > 0:
        tasks -= 1
        start, length = starts[tasks], lengths[tasks]
        if combine[tasks]:
            results -= 1
            partial[results - 1] = partial[results - 1] + partial[results]
        elif length <= 128:
            partial[results] = block_sum(values, start, length)
            results += 1
        else:
            half = length // 2
            half -= half % 8
            # Done in reverse order: the first half, the second, then their sum.
            starts[tasks], lengths[tasks], combine[tasks] = start, length, True
            starts[tasks + 1], lengths[tasks + 1], combine[tasks + 1] = (
                start + half,
                length - half,
                False,
            )
            starts[tasks + 2], lengths[tasks + 2], combine[tasks + 2] = start, half, False
            tasks += 3
    return partial[0]
