"""A triangular solve that lets other threads run while it works.

scipy's :func:`scipy.linalg.solve_triangular` holds Python's GIL for the
whole LAPACK call, so two threads that solve at once take turns: the
low-rank module-3 path (:mod:`skmba.calibration._module3_low_rank`), whose
draws :func:`~skmba._core.threads.stack_map` splits over the threads of a
``blas_threads`` block, gained nothing from the second thread. numpy's
batched factorisations release the GIL, numpy has no triangular solve.

:func:`lower_solve` calls the same BLAS routine (``dtrsm``, from scipy's
Cython BLAS, the library scipy links) through :mod:`ctypes`, which releases
the GIL during a foreign call: the same bits as ``solve_triangular`` (checked
in ``tests/core/test_triangular.py``), on as many threads as call it.
Measurements: docs/internals.rst, section
skmba.calibration._module3_mixture.

Examples
--------
>>> import numpy as np
>>> from skmba._core.triangular import lower_solve
>>> L = np.array([[2.0, 0.0], [1.0, 1.0]])
>>> lower_solve(L, np.array([[2.0], [3.0]])).ravel().tolist()
[1.0, 2.0]
"""

import ctypes
import functools

import numpy as np
from scipy.linalg import cython_blas

_DOUBLES = ctypes.POINTER(ctypes.c_double)
_INT = ctypes.POINTER(ctypes.c_int)


@functools.cache
def _dtrsm():
    """scipy's ``dtrsm`` as a ctypes function (found once per process)."""
    capsule = cython_blas.__pyx_capi__["dtrsm"]
    name = ctypes.pythonapi.PyCapsule_GetName
    name.restype, name.argtypes = ctypes.c_char_p, [ctypes.py_object]
    pointer = ctypes.pythonapi.PyCapsule_GetPointer
    pointer.restype = ctypes.c_void_p
    pointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
    address = pointer(capsule, name(capsule))
    chars = [ctypes.c_char_p] * 4
    signature = [*chars, _INT, _INT, _DOUBLES, _DOUBLES, _INT, _DOUBLES, _INT]
    # CFUNCTYPE, not PYFUNCTYPE: the call releases the GIL.
    return ctypes.CFUNCTYPE(None, *signature)(address)


def lower_solve(L, B):
    """``L^-1 B`` for a lower triangular ``L`` (m, m) and ``B`` (m, n).

    Parameters
    ----------
    L : ndarray of shape (m, m)
        Lower triangular with a nonzero diagonal (e.g. a Cholesky factor);
        the entries above the diagonal are not read.
    B : ndarray of shape (m, n)

    Returns
    -------
    ndarray of shape (m, n), Fortran order
        The solution, bit for bit ``scipy.linalg.solve_triangular(L, B,
        lower=True)``; its transpose is C-contiguous.

    Raises
    ------
    ValueError
        When the shapes do not match.
    """
    L = np.asarray(L, dtype=float)
    if L.ndim != 2 or L.shape[0] != L.shape[1] or np.ndim(B) != 2:
        raise ValueError(
            f"L must be square and B two-dimensional, got {L.shape} and "
            f"{np.shape(B)}: pass one factor and one block of right-hand sides."
        )
    if len(B) != len(L):
        raise ValueError(
            f"B has {len(B)} rows for an L of order {len(L)}: pass the "
            "right-hand sides as columns."
        )
    X = np.array(B, dtype=float, order="F")  # solved in place
    m, n = X.shape
    if m == 0 or n == 0:
        return X
    if L.flags.f_contiguous:  # L itself, lower
        A, uplo, trans = L, b"L", b"N"
    else:  # read as Fortran, a C-ordered L is L': upper, transposed
        A, uplo, trans = np.ascontiguousarray(L), b"U", b"T"
    _dtrsm()(
        b"L",
        uplo,
        trans,
        b"N",
        ctypes.byref(ctypes.c_int(m)),
        ctypes.byref(ctypes.c_int(n)),
        ctypes.byref(ctypes.c_double(1.0)),
        A.ctypes.data_as(_DOUBLES),
        ctypes.byref(ctypes.c_int(m)),
        X.ctypes.data_as(_DOUBLES),
        ctypes.byref(ctypes.c_int(m)),
    )
    return X
