"""Module 2, step 2: the emulator integrated over the prior of theta.

At the field inputs ``X_e`` the model output is unknown because ``theta``
is. Module 2 replaces it by the emulator averaged over the prior (thesis
Eqs. 4.13-4.17)::

    m_bar(x_i)    = ∫ E[y_m(x_i, θ) | D_m] p(θ) dθ                     (4.14)
    V_cond[i, j]  = ∫ Cov[y_m(x_i, θ), y_m(x_j, θ) | D_m] p(θ) dθ       (4.15)
                  = Sigma_m ⊗ ∫ c(x_i, x_j; θ) p(θ) dθ                  (4.17)

where ``c`` is the emulator's universal-kriging correlation at the two
points with the same ``θ``. Eq. 4.15 keeps only this conditional
covariance. The law of total variance also adds the spread of the emulator
mean over the prior,

    V_spread[(i, a), (j, b)] = ∫ (m_a(x_i, θ) - m_bar_a(x_i))
                                 (m_b(x_j, θ) - m_bar_b(x_j)) p(θ) dθ,

which tells the discrepancy GP how much of the field data the unknown
``theta`` can already explain; :func:`integrate_emulator` returns both.

The integrals use the prior's nodes and weights (Gauss-Legendre on the
prior quantiles for one parameter, scrambled Sobol points for several, see
:mod:`skmba.priors._theta`), vectorised over nodes and parallel over blocks of
nodes through joblib. :func:`prior_units` measures, with the same nodes,
the spread of the model's response over the field inputs and the prior:
the unit the discrepancy prior's size is stated in
(:class:`~skmba.priors._hyperprior.PriorUnits`).

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._module2_prior_integral import weighted_moments
>>> mean, spread = weighted_moments(np.array([[[1.0]], [[3.0]]]), np.array([0.5, 0.5]))
>>> mean.ravel(), spread.ravel()
(array([2.]), array([1.]))
"""

from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

from skmba._core.linalg import FEWER_FIELD_DATA, FLOAT_BYTES, check_memory, n_workers
from skmba._core.threads import BlasTask
from skmba._core.warn import warn
from skmba.priors._hyperprior import PriorUnits

MODULE2_VARIANCES = ("total", "conditional")
INTEGRATIONS = ("auto", "quadrature", "qmc")
#: Default number of integration nodes per rule.
DEFAULT_NODES = {"quadrature": 32, "qmc": 256}

#: Nodes of the prior over which :func:`prior_units` measures the model's
#: spread (a fixed rule: the prior's units never depend on ``random_state``).
UNITS_NODES = 32
UNITS_SEED = 0

# Bytes of the (k, n, n) correlation temporaries of one block of nodes: the
# number of nodes per block is lowered so that they stay below this.
BLOCK_BYTES = 64 * 2**20


def nodes_per_block(n, block=64):
    """Number of integration nodes per block for ``n`` field inputs.

    At most ``block``, and few enough that a block's three (k, n, n)
    temporaries fit in :data:`BLOCK_BYTES`. It depends on the problem only
    (never on ``n_jobs``), so the blocks, hence the bits, are the same for
    any ``n_jobs``.

    Examples
    --------
    >>> nodes_per_block(20), nodes_per_block(1000)
    (64, 2)
    """
    return int(max(1, min(block, BLOCK_BYTES // (3 * 8 * max(n, 1) ** 2))))


def _node_block(emulator, X_e, nodes, weights):
    """Emulator means (k, n, q) at the nodes and ``sum_k w_k c_k`` (n, n).

    Run as a :class:`~skmba._core.threads.BlasTask`: its work is triangular
    solves and products, whose bits do not depend on the BLAS threads, so a
    block gives the same bits in any joblib worker as in the calling process.
    """
    cond = emulator.conditional(X_e, nodes)
    corr = cond.universal_correlation()
    return cond.mean(), np.tensordot(weights, corr, axes=1)


def weighted_moments(values, weights):
    """Weighted mean and covariance over the first axis.

    Parameters
    ----------
    values : ndarray of shape (k, n, q)
    weights : ndarray of shape (k,)
        Non-negative, summing to one.

    Returns
    -------
    mean : ndarray of shape (n, q)
    spread : ndarray of shape (n q, n q)
        ``sum_k w_k (v_k - mean)(v_k - mean)'`` with ``v_k`` vectorised
        response-slowest (``vec`` of the (n, q) array), matching
        ``Sigma ⊗ R`` layouts.
    """
    mean = np.tensordot(weights, values, axes=1)
    centred = (values - mean).transpose(0, 2, 1).reshape(len(weights), -1)
    spread = (centred * weights[:, None]).T @ centred
    return mean, spread


def integrate_emulator(emulator, X_e, nodes, weights, *, n_jobs=None, block=64):
    """Prior-integrated emulator moments at the field inputs (Eqs. 4.14-4.17).

    Parameters
    ----------
    emulator : Emulator
        The fitted module-1 emulator (standardised units).
    X_e : ndarray of shape (n, d)
        Standardised field inputs.
    nodes : ndarray of shape (k, r)
        Standardised integration nodes.
    weights : ndarray of shape (k,)
    n_jobs : int, default=None
        Blocks of nodes run in parallel through joblib. The blocks are fixed
        by ``block`` and ``n``, not by ``n_jobs``, and each is computed with
        one BLAS thread: the result is bit-identical for any ``n_jobs`` and
        backend.
    block : int, default=64
        Largest number of nodes per block (lowered for many field inputs,
        see :func:`nodes_per_block`). Each block returns its weighted sum of
        correlations, so the memory is that of the blocks in flight, not of
        all nodes.

    Returns
    -------
    mean : ndarray of shape (n, q)
        ``m_bar`` of Eq. 4.14.
    cond_corr : ndarray of shape (n, n)
        The integrated correlation of Eq. 4.17: the conditional covariance of
        Eq. 4.15 is ``Sigma_m ⊗ cond_corr``.
    spread : ndarray of shape (n q, n q)
        The covariance of the emulator mean over the prior (law of total
        variance), ``vec`` ordering response-slowest.
    """
    block = nodes_per_block(len(X_e), block)
    starts = range(0, len(nodes), block)
    task = BlasTask(_node_block, len(emulator.Z), n_jobs)
    with task.held():
        parts = Parallel(n_jobs=n_jobs)(
            delayed(task)(emulator, X_e, nodes[s : s + block], weights[s : s + block])
            for s in starts
        )
    means = np.concatenate([p[0] for p in parts])
    mean, spread = weighted_moments(means, weights)
    cond_corr = parts[0][1]
    for part in parts[1:]:  # in block order, whatever finished first
        cond_corr = cond_corr + part[1]
    return mean, 0.5 * (cond_corr + cond_corr.T), 0.5 * (spread + spread.T)


def one_parameter_rule(name, value, r, *, one="quadrature", several):
    """Resolve a rule that has a one-parameter form (``"auto"`` included).

    ``"auto"`` means ``one`` for one parameter and ``several`` otherwise;
    ``one`` with several parameters is an error naming the fix.

    Examples
    --------
    >>> one_parameter_rule("integration", "auto", 2, several="qmc")
    'qmc'
    """
    if value == "auto":
        return one if r == 1 else several
    if value == one and r != 1:
        raise ValueError(
            f"{name}={one!r} needs one parameter, the prior has {r}; use "
            f"{name}={several!r} (or 'auto')."
        )
    return value


def repair_psd(V, magnitude=None):
    """Symmetrise; add the smallest jitter that makes V positive definite.

    The integrated covariance is positive semi-definite in exact
    arithmetic; round-off (or a kernel that is not positive definite)
    can break that. The jitter is ``max(0, -lambda_min) + 1e-10 * mean
    variance`` on the diagonal, with a warning when it exceeds round-off:
    ``1e-8`` times ``magnitude``, the size of the terms whose difference
    ``V`` is (the emulator's prior variance: over a narrow posterior the
    integrated covariance is far smaller than the terms it cancels), by
    default the mean variance of ``V``.

    Examples
    --------
    >>> bool(repair_psd(np.eye(2))[0, 0] > 1.0)
    True
    """
    V = 0.5 * (V + V.T)
    smallest = np.linalg.eigvalsh(V)[0]
    scale = np.trace(V) / len(V)
    jitter = max(0.0, -smallest) + 1e-10 * scale
    if -smallest > 1e-8 * (scale if magnitude is None else max(magnitude, scale)):
        warn(
            "The integrated emulator covariance of module 2 was not positive "
            f"definite (smallest eigenvalue {smallest:.3g}); a jitter of "
            f"{jitter:.3g} was added. Consider another model kernel "
            "(Gauss, Exp) or more integration nodes.",
            UserWarning,
        )
    return V + jitter * np.eye(len(V))


@dataclass(frozen=True)
class IntegratedEmulator:
    """Module 2a: the emulator integrated over the prior at the field inputs.

    Attributes
    ----------
    mean : ndarray of shape (n, q)
        ``m_bar`` (Eq. 4.14), standardised.
    cov : ndarray of shape (n q, n q)
        Eq. 4.15, plus the spread of the mean for ``"total"``; repaired to
        be positive definite.
    """

    mean: np.ndarray
    cov: np.ndarray

    def restrict(self, responses):
        """The moments of some responses (columns) only."""
        n = len(self.mean)
        rows = np.concatenate([np.arange(a * n, (a + 1) * n) for a in responses])
        return IntegratedEmulator(
            self.mean[:, list(responses)], self.cov[np.ix_(rows, rows)]
        )


def integrate_over_rule(emulator, X_e, nodes, weights, *, n_jobs=None):
    """Module 2a over a rule of standardised thetas, e.g. a posterior's.

    The ``"total"`` moments (the spread of the emulator mean over the rule
    included), repaired to be positive definite. The caller bounds the
    memory: a posterior's rule has no more nodes than the prior's.
    """
    mean, corr, spread = integrate_emulator(
        emulator, X_e, nodes, weights, n_jobs=n_jobs
    )
    V = np.kron(emulator.sigma2, corr) + spread
    return IntegratedEmulator(mean, repair_psd(V, np.max(np.diag(emulator.sigma2))))


def integrate_over_prior(
    emulator,
    scaler,
    prior,
    X_e,
    *,
    rule="auto",
    n_nodes=None,
    variance="total",
    n_jobs=None,
    random_state=None,
):
    """Module 2a at standardised field inputs ``X_e`` (Eqs. 4.14-4.17).

    Parameters
    ----------
    emulator : Emulator
    scaler : Standardizer
    prior : skmba prior object
    X_e : ndarray of shape (n, d)
        Standardised field inputs.
    rule : {"auto", "quadrature", "qmc"}
    n_nodes : int, default=None
        Nodes of the rule (None: :data:`DEFAULT_NODES`).
    variance : {"total", "conditional"}
        ``"total"`` adds the spread of the emulator mean over the prior
        (law of total variance) to Eq. 4.15.
    n_jobs : int, default=None
    random_state : int or None
        Seed of the nodes (QMC).

    Returns
    -------
    IntegratedEmulator
    """
    rule = one_parameter_rule("integration", rule, prior.dim, several="qmc")
    nodes, weights = prior.integration_nodes(
        n_nodes or DEFAULT_NODES[rule], random_state=random_state
    )
    n, N, q = len(X_e), emulator.N, emulator.q
    block = nodes_per_block(n)
    jobs = min(n_workers(n_jobs), -(-len(nodes) // block))
    # Blocks in flight (three (k, n, n) correlation temporaries and the
    # (N, k n) cross-correlations each), the node means, and the nq x nq
    # covariance with its spread and repair copies.
    needed = FLOAT_BYTES * (
        jobs * (3 * block * n * n + 2 * N * block * n)
        + len(nodes) * n * q
        + 4 * (n * q) ** 2
    )
    check_memory(
        needed,
        f"Module 2 (the emulator integrated over the prior at {n} field "
        f"inputs x {q} responses, {len(nodes)} nodes)",
        FEWER_FIELD_DATA,
    )
    mean, corr, spread = integrate_emulator(
        emulator, X_e, scaler.theta(nodes), weights, n_jobs=n_jobs
    )
    V = np.kron(emulator.sigma2, corr)
    if variance == "total":
        V = V + spread
    return IntegratedEmulator(mean, repair_psd(V))


def prior_units(emulator, scaler, prior, X_e):
    """The field data's units of the discrepancy prior
    (:class:`~skmba.priors._hyperprior.PriorUnits`).

    Per design variable, the ratio of the simulations' standard deviation
    to that of the distinct standardised field inputs ``X_e`` (1 where
    they do not vary); per response, the spread of the emulator mean over
    ``X_e`` and :data:`UNITS_NODES` nodes of the prior of theta (standard
    deviation under equal weights over the inputs and the prior's
    weights), in the simulations' standardised units (1 where the model
    does not vary). Both depend on the field inputs, the prior and the
    model, not on the simulation design.
    """
    X_e = np.unique(np.asarray(X_e, dtype=float), axis=0)
    spread_x = X_e.std(axis=0)
    input_ratio = np.where(spread_x > 0, 1.0 / np.where(spread_x > 0, spread_x, 1), 1)
    nodes, weights = prior.integration_nodes(UNITS_NODES, random_state=UNITS_SEED)
    thetas = scaler.theta(nodes)
    # Blocks of nodes keep the (N, k n) cross-correlations small.
    block = max(1, BLOCK_BYTES // (FLOAT_BYTES * emulator.N * len(X_e)))
    means = np.concatenate(
        [
            emulator.conditional(X_e, thetas[i : i + block]).mean()
            for i in range(0, len(thetas), block)
        ]
    )  # (k, n, q)
    w = weights[:, None, None] / len(X_e)
    centre = np.sum(w * means, axis=(0, 1))
    spread_y = np.sqrt(np.sum(w * (means - centre) ** 2, axis=(0, 1)))
    tiny = 1e-12 * max(1.0, float(np.max(np.abs(centre))))
    response_ratio = np.where(spread_y > tiny, spread_y, 1.0)
    return PriorUnits(tuple(input_ratio), tuple(response_ratio))
