"""Keep freed encoder activations in the heap (glibc ``mallopt``), so batches stop page-faulting.

Layer: nvrq core, encoders.

glibc serves large blocks (one efficientnet-lite0 activation is ~150 MB at batch 32) with
``mmap`` and hands them back to the kernel on ``free``; the next batch faults every page in
again. Measured on the 2-core machine (efficientnet-lite0, batch 32, 3 batches): 1.3 M page
faults and ~2 s of kernel time per 3 batches as shipped, 12-50 k faults and < 0.1 s with
``M_MMAP_MAX = 0`` (large blocks come from the heap) and ``M_TRIM_THRESHOLD = INT_MAX`` (the
heap is not trimmed after each batch); identical embeddings (re-measure with
``benchmarks/bench_score.py``). The cost: the process keeps its peak heap.

>>> tune_allocator() in (True, False)
True
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["tune_allocator"]

M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
_INT_MAX = 2**31 - 1  # mallopt takes a C int

_done: list[bool] = []


def tune_allocator() -> bool:
    """Apply the two glibc settings once per process; ``False`` where glibc is absent.

    Returns
    -------
    bool
        Whether the settings apply.
    """
    if _done:
        return _done[0]
    ok = False
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
            ok = bool(libc.mallopt(M_MMAP_MAX, 0)) and bool(libc.mallopt(M_TRIM_THRESHOLD, _INT_MAX))
        except (OSError, AttributeError):  # musl or another libc without mallopt
            ok = False
    _done.append(ok)
    return ok
