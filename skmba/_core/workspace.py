"""Scratch arrays reused across calls, one buffer per thread.

* :func:`scratch`: an uninitialised array in the calling thread's buffer,
  for a large temporary that a hot loop builds on every call and discards
  before returning (the bordered stacks of
  :func:`~skmba._core.linalg.stacked_whitening`, the per-dimension
  differences of the DACE correlations in :mod:`skmba._core.dace`).

Allocating such a temporary afresh each time lets glibc's allocator give the
memory back to the system and fault it in again at the next call, which
costs system time in page faults rather than arithmetic (measured:
docs/internals.rst, section skmba._core.workspace).

Examples
--------
>>> a = scratch((2, 3))
>>> a.shape
(2, 3)
>>> scratch((3, 2)).base is a.base  # the same memory, reshaped
True
"""

import math
import threading

import numpy as np

#: The largest scratch array a thread keeps (bytes); larger requests get a
#: fresh array.
SCRATCH_BYTES = 2**24

_local = threading.local()


def scratch(shape):
    """An uninitialised float64 array of ``shape`` in the thread's buffer.

    It holds whatever the last use left: write every entry that is read.
    It is valid until the thread's next call of :func:`scratch`, so it must
    not leave the computation that asked for it (a helper may hand it to
    its caller, which uses it up before asking again).
    """
    size = math.prod(shape)
    if 8 * size > SCRATCH_BYTES:
        return np.empty(shape)
    buffer = getattr(_local, "buffer", None)
    if buffer is None or buffer.size < size:
        buffer = _local.buffer = np.empty(size)
    return buffer[:size].reshape(shape)
