"""Module 3 for every response subset at once, along a prefix tree (sensor design).

An exhaustive sensor search evaluates Eq. 4.30 for the ``2^q - 1`` response
subsets of each replicate, at the same thetas and with the same module-2
draws. The subsets' field covariances are principal submatrices of one
``nq x nq`` matrix (responses in blocks of ``n`` rows)::

    S[a, b](theta) = Sigma_d[a, b] R_d + delta_ab lambda_a I + Sigma_m[a, b] T(theta)

and, with the responses of a subset in increasing order, a subset's block
Cholesky factor extends that of the subset without its last response (its
parent in the prefix tree): for ``T = P + {a}``::

    L_T = [[L_P, 0], [U_P[a]', F_a]],   U_P[a] = L_P^-1 S[P, a],
    F_a F_a' = S[a, a] - U_P[a]' U_P[a]

and the columns ``U_T[b] = [U_P[b]; F_a^-1 (S[a, b] - U_P[a]' U_P[b])]`` of
the responses ``b`` that follow in some subset are carried down the tree,
as are the whitened field rows of the regression and the data. Each tree
node then costs one ``n x n`` factorisation and products with the
``n |P|`` rows of its parent, where factoring every subset on its own costs
``(n |T|)^3 / 3`` (measured: docs/internals.rst, section
skmba.sensor_design._subset_tree). The regression is
integrated out per subset by the QR shared with the calibrator
(:func:`~skmba.calibration._module3_likelihood.regression_log_likelihoods`).

Examples
--------
``tests/sensor_design/test_subset_tree.py`` checks :func:`subset_tree_log_likelihoods`
against :class:`~skmba.sensor_design._subset_likelihood.SubsetLikelihood`, subset by
subset:

>>> from skmba.sensor_design._subset_tree import FieldTerms, subset_tree_log_likelihoods
"""

from typing import NamedTuple

import numpy as np
from scipy import linalg

from skmba.calibration._module3_likelihood import regression_log_likelihoods

#: From this many field points on, a node's new rows are whitened by one
#: triangular solve per matrix of the stack; below, numpy's batched solve
#: (which factors the triangular ``F_a`` again by LU) is as fast, in one call
#: (docs/internals.rst, section skmba.sensor_design._subset_tree).
TRIANGULAR_MIN_N = 24


class FieldTerms(NamedTuple):
    """The field data and module-2 terms of one likelihood (all ``q`` responses).

    Attributes
    ----------
    Y_e : ndarray of shape (n, q)
        Field data (standardised).
    R_d : ndarray of shape (n, n)
        Discrepancy correlation at the field design.
    sigma2_d : ndarray of shape (q, q)
        Discrepancy covariance of the responses.
    noise : ndarray of shape (q,)
        Noise variances.
    """

    Y_e: np.ndarray
    R_d: np.ndarray
    sigma2_d: np.ndarray
    noise: np.ndarray


class _Node(NamedTuple):
    """What a tree node passes to its children (leading axis: field x theta).

    ``G`` holds, on the path's ``n |path|`` whitened rows, the columns
    ``L^-1 S[path, f]`` of each later response ``f`` of ``future`` (``n``
    each), then the whitened regression (``p_m + p_d`` per path response)
    and the whitened data (one): one array, so that a child takes all its
    products with the path's rows in one product and one solve.
    """

    path: tuple  # its responses, increasing
    G: np.ndarray  # (b, n |path|, n |future| + (p_m + p_d) |path| + 1)
    future: tuple  # the responses of G's leading column blocks
    log_det: np.ndarray  # (b,): log |S_path|
    alive: np.ndarray  # (b,) bool: S_path positive definite


def _prefixes(subsets):
    """For every prefix of the (sorted) subsets: the responses that come
    next (its children) and all that follow it in some subset (the
    columns its descendants need)."""
    children, needed = {}, {}
    for subset in subsets:
        for m in range(len(subset)):
            children.setdefault(subset[:m], set()).add(subset[m])
            needed.setdefault(subset[:m], set()).update(subset[m:])
    return (
        {prefix: tuple(sorted(after)) for prefix, after in children.items()},
        {prefix: tuple(sorted(after)) for prefix, after in needed.items()},
    )


def subset_tree_log_likelihoods(design, subsets, fields, H_d, pieces):
    """Eq. 4.30 for many response subsets, fields and thetas, along a prefix tree.

    Parameters
    ----------
    design : FieldDesignEmulator
        The emulator's pieces at the field design.
    subsets : sequence of tuple of int
        Response subsets, each in increasing order.
    fields : sequence of FieldTerms
        One field likelihood each (a replicate's data with one module-2
        draw).
    H_d : ndarray of shape (n, p_d)
        Discrepancy regression matrix.
    pieces : tuple
        ``design.pieces(thetas)`` at ``k`` thetas.

    Returns
    -------
    ndarray of shape (len(subsets), len(fields), k)
        ``-inf`` where a subset's covariance is not positive definite.

    Raises
    ------
    FactorizationError
        When the regression is rank deficient (see
        :func:`~skmba.calibration._module3_likelihood.regression_log_likelihoods`).
    """
    T, H_me, M = pieces
    k, n = T.shape[:2]
    c = len(fields)
    b = c * k
    p_m, p_d = H_me.shape[2], H_d.shape[1]
    p = p_m + p_d
    sigma2_m = design.emulator.sigma2
    R_d = np.stack([f.R_d for f in fields])
    sigma2_d = np.stack([f.sigma2_d for f in fields])
    noise = np.stack([np.asarray(f.noise, dtype=float) for f in fields])
    # The field rows of the regression and the data, per response: the
    # model's regression at each theta, the discrepancy's, and the data
    # less the emulator's conditional mean.
    H_rows = np.concatenate(
        [np.broadcast_to(H_me, (c, k, n, p_m)), np.broadcast_to(H_d, (c, k, n, p_d))],
        axis=3,
    ).reshape(b, n, p)
    Y = np.stack([f.Y_e for f in fields])  # (c, n, q)
    eye = np.eye(n)

    def covariance(a, others):
        """``S[a, others]`` at every (field, theta): ``(b, n, n |others|)``."""
        others = list(others)
        out = (
            sigma2_d[:, a, others][:, None, None, :, None] * R_d[:, None, :, None, :]
            + sigma2_m[a, others][None, None, None, :, None] * T[None, :, :, None, :]
        )
        for j, other in enumerate(others):
            if other == a:
                out[:, :, :, j, :] += noise[:, a, None, None, None] * eye
        return out.reshape(b, n, n * len(others))

    index = {subset: i for i, subset in enumerate(subsets)}
    children, futures = _prefixes(subsets)
    out = np.empty((len(subsets), c, k))
    root = _Node(
        (),
        np.zeros((b, 0, n * len(futures[()]) + 1)),
        futures[()],
        np.zeros(b),
        np.ones(b, dtype=bool),
    )
    # Depth first, a child made only when it is visited: the nodes held are
    # those of the current path (each referenced by its pending children).
    stack = [(root, a) for a in reversed(children[()])]
    while stack:
        node, a = stack.pop()
        child = _extend(node, a, futures, covariance, H_rows, Y, M, n, p)
        if child.path in index:
            out[index[child.path]] = _log_likelihood(
                design, child, n, p_m, p_d
            ).reshape(c, k)
        stack.extend((child, later) for later in reversed(children.get(child.path, ())))
    return out


def path_bytes(n, q, p):
    """Bytes one (field, theta) needs along a path of the prefix tree.

    The carried columns of the nodes on a path of all ``q`` responses
    (``n`` field inputs, ``p`` regression columns per response): at depth
    ``j``, ``n j`` rows of the ``n (q - j)`` later responses' columns,
    ``p j`` regression columns and the data; the most the depth-first walk
    holds at once.

    Examples
    --------
    >>> path_bytes(12, 9, 2), path_bytes(12, 1, 2)
    (197280, 288)
    """
    return 8 * sum(n * j * (n * (q - j) + p * j + 1) for j in range(1, q + 1))


def _extend(node, a, futures, covariance, H_rows, Y, M, n, p):
    """The child ``node.path + (a,)`` of a tree node."""
    path = (*node.path, a)
    future = futures.get(path, ())  # all later responses of its subsets
    b, rows = len(node.alive), n * len(node.path)
    blocks = {r: j for j, r in enumerate(node.future)}
    m_u = n * len(node.future)  # the tail: the regression and the data
    first = blocks[a]
    if [blocks[r] for r in future] == list(range(first + 1, len(node.future))):
        # a and its future are the last blocks (an exhaustive search): a view.
        taken = node.G[:, :, n * first :]
    else:
        columns = np.concatenate(
            [np.arange(n * blocks[r], n * (blocks[r] + 1)) for r in (a, *future)]
            + [np.arange(m_u, node.G.shape[2])]
        )
        taken = node.G[:, :, columns]
    # taken: [U_a, U_rest, W_reg, w_y] on the path rows.
    m_rest = n * len(future)
    # The covariance of response a and of the responses that follow it,
    # given the path (a Schur complement), and the field rows of a less
    # their regression on the path's rows, in one product.
    given = np.swapaxes(taken[:, :, :n], 1, 2) @ taken  # U_a' [...]
    S_a = covariance(a, (a, *future))
    C_aa = S_a[:, :, :n] - given[:, :, :n]
    F_a, alive = _factor(0.5 * (C_aa + np.swapaxes(C_aa, 1, 2)), node.alive)
    y_a = (Y[:, None, :, a] - M[None, :, :, a]).reshape(b, n)
    rhs = np.concatenate(
        [
            S_a[:, :, n:] - given[:, :, n : n + m_rest],
            -given[:, :, n + m_rest : -1],
            H_rows,
            (y_a - given[:, :, -1])[:, :, None],
        ],
        axis=2,
    )
    G = np.empty((b, rows + n, rhs.shape[2]))
    # The path rows, zero in the new regression columns; then the new rows.
    width = taken.shape[2] - n - 1
    G[:, :rows, :width] = taken[:, :, n:-1]
    G[:, :rows, width:-1] = 0.0
    G[:, :rows, -1] = taken[:, :, -1]
    _whiten(F_a, rhs, out=G[:, rows:])  # F_a^-1 [...]
    return _Node(
        path,
        G,
        future,
        node.log_det + 2.0 * np.sum(np.log(np.diagonal(F_a, axis1=1, axis2=2)), axis=1),
        alive,
    )


def _whiten(F, rhs, out):
    """``F_j^-1 rhs_j`` into ``out`` for a stack of lower-triangular ``F``."""
    if F.shape[1] < TRIANGULAR_MIN_N:
        out[...] = np.linalg.solve(F, rhs)
        return
    for j, (factor, columns) in enumerate(zip(F, rhs, strict=True)):
        out[j] = linalg.solve_triangular(
            factor, columns, lower=True, check_finite=False
        )


def _factor(C, alive):
    """Cholesky factors of a stack; a matrix that is not positive definite
    (or whose path already was not) is replaced by the identity and marked."""
    alive = alive & np.all(np.isfinite(C), axis=(1, 2))
    C = np.where(alive[:, None, None], C, np.eye(C.shape[1]))
    try:
        return np.linalg.cholesky(C), alive
    except np.linalg.LinAlgError:
        F = np.empty_like(C)
        alive = alive.copy()
        for j, matrix in enumerate(C):
            try:
                F[j] = np.linalg.cholesky(matrix)
            except np.linalg.LinAlgError:
                F[j] = np.eye(len(matrix))
                alive[j] = False
        return F, alive


def _log_likelihood(design, node, n, p_m, p_d):
    """Eq. 4.30 of a tree node's subset (``-inf`` where it is not alive)."""
    s = len(node.path)
    _, G, b_top, rss_perp, log_det_A = design.simulation_block(node.path)
    P = (p_m + p_d) * s
    top = np.zeros((p_m * s, P + 1))
    top[:, : p_m * s] = G
    top[:, P] = b_top
    # W_reg holds [model, discrepancy] columns per response; the simulation
    # block orders them as all models, then all discrepancies.
    per = np.arange(s)[:, None] * (p_m + p_d)
    order = np.concatenate(
        [(per + np.arange(p_m)).ravel(), (per + p_m + np.arange(p_d)).ravel()]
    )
    tail = node.G[:, :, n * len(node.future) :]  # [W_reg, w_y]
    W = tail[:, :, np.append(order, P)]
    out = np.full(len(node.alive), -np.inf)
    if node.alive.any():
        M = (design.N + design.n) * s
        out[node.alive] = regression_log_likelihoods(
            node.log_det[node.alive], W[node.alive], top, rss_perp, log_det_A, M
        )
    return out
