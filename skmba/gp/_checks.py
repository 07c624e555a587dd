"""Checks of the training data of :class:`skmba.MultiResponseGP`.

Each refuses, with a ``ValueError`` that names the fix, data that sklearn's
own checks let through but that no Gaussian process can be fitted to: values
whose squares overflow float64, too few samples for the regression terms or
for the response covariance, identical inputs, regression terms that the
inputs cannot identify and, without noise, duplicated inputs with different
responses; :func:`check_fit_memory` refuses, with a ``MemoryError`` that
names the remedy, a fit whose matrices would not fit in memory. After the
fit, :func:`warn_at_bounds` reports kernel
hyperparameters and noise variances held by a bound of their search.

Examples
--------
>>> from skmba.gp._checks import check_sample_size
>>> check_sample_size(n=3, d=1, p=2, regression="linear")
>>> check_sample_size(n=2, d=1, p=2, regression="linear")
Traceback (most recent call last):
...
ValueError: n_samples=2 is too few for regression='linear' ... 3 samples are needed...
"""

import numpy as np
from sklearn.exceptions import ConvergenceWarning

from skmba._core.dace import DACECorrelation
from skmba._core.linalg import check_memory
from skmba._core.warn import warn
from skmba.gp._search import LOG_NOISE_BOUNDS

# Inputs and responses beyond this magnitude overflow float64 when squared.
_MAX_MAGNITUDE = 1e150


def check_magnitudes(X, Y):
    """Refuse values whose squares overflow or underflow float64."""
    for name, A, remedy in (
        (
            "X",
            X,
            "Rescale the inputs, e.g. with sklearn.preprocessing.StandardScaler "
            "in a Pipeline.",
        ),
        (
            "y",
            Y,
            "Express the responses in other units (divide y by a constant); "
            "sigma2_ is in squared units of y.",
        ),
    ):
        peak = float(np.max(np.abs(A))) if A.size else 0.0
        if peak > _MAX_MAGNITUDE:
            raise ValueError(
                f"{name} has values up to {peak:.3g} in magnitude, beyond "
                f"{_MAX_MAGNITUDE:.0e}: their squares overflow float64. {remedy}"
            )
    for name, A, effect, remedy in (
        (
            "X column(s)",
            X,
            "the kernel roughness for them overflows float64",
            "Rescale the inputs, e.g. with sklearn.preprocessing.StandardScaler "
            "in a Pipeline, or drop the columns.",
        ),
        (
            "Response(s)",
            Y,
            "their variances underflow float64",
            "Express the responses in other units (multiply y by a constant).",
        ),
    ):
        span = np.ptp(A, axis=0)
        tiny = (span > 0) & (span < 1.0 / _MAX_MAGNITUDE)
        if np.any(tiny):
            raise ValueError(
                f"{name} {np.flatnonzero(tiny).tolist()} vary by less than "
                f"{1.0 / _MAX_MAGNITUDE:.0e} (range {span[tiny].min():.3g}): "
                f"{effect}. {remedy}"
            )


def check_regression_rank(X, H, regression):
    """ValueError naming the cause when the regression terms are not identifiable."""
    p = H.shape[1]
    scaled = H / np.maximum(np.abs(H).max(axis=0), np.finfo(float).tiny)
    singular = np.linalg.svd(scaled, compute_uv=False)
    rank = int(np.sum(singular > 1e-10 * singular[0]))
    if rank == p:
        return
    constant = np.flatnonzero(np.ptp(X, axis=0) == 0)
    if regression != "constant" and constant.size:
        cause = (
            f"X column(s) {constant.tolist()} are constant, so their "
            f"{regression} terms duplicate the intercept"
        )
    else:
        n_distinct = len(np.unique(X, axis=0))
        cause = (
            f"its {p} terms have rank {rank} on these inputs ({n_distinct} "
            "distinct rows of X; collinear columns also cause this)"
        )
    raise ValueError(
        f"regression={regression!r} cannot be estimated: {cause}. Use a "
        "lower-order regression ('constant' needs only distinct inputs), drop "
        "constant or collinear columns of X, or add distinct input points."
    )


def check_rows(X, Y, H, regression, noise):
    """Identical rows, unidentifiable regression, noise-free duplicates.

    Duplicated rows with equal ``y`` only warn; the warning points at the
    caller of ``MultiResponseGP.fit`` (called from its ``_fit``).
    """
    n = len(X)
    _, first, inverse = np.unique(X, axis=0, return_index=True, return_inverse=True)
    if len(first) == 1:
        raise ValueError(
            f"All {n} rows of X are identical: the GP cannot learn how the "
            "responses vary with the inputs. Provide at least 2 distinct "
            "input points."
        )
    check_regression_rank(X, H, regression)
    if noise or len(first) == n:
        return
    source = first[np.reshape(inverse, -1)]  # first occurrence of each row
    dup = np.flatnonzero(source != np.arange(n))
    tol = 1e-8 * np.ptp(Y, axis=0)
    differ = np.any(np.abs(Y[dup] - Y[source[dup]]) > tol, axis=1)
    if np.any(differ):
        i = dup[np.argmax(differ)]
        raise ValueError(
            f"X has {int(differ.sum())} duplicated row(s) with different y "
            f"(e.g. rows {source[i]} and {i}): a noise-free GP "
            "interpolates and cannot pass through both. Fit with "
            "noise=True (measurements, stochastic simulators), or average "
            "the duplicated runs."
        )
    warn(
        f"X has {dup.size} duplicated row(s) (e.g. rows {source[dup[0]]} and "
        f"{dup[0]}) with equal y: they add no information to a noise-free "
        "GP and make the correlation matrix singular up to the nugget "
        "alpha. Remove them to save time.",
        UserWarning,
    )


def check_sample_size(n, d, p, regression):
    """More samples ``n`` than regression terms ``p`` (``d`` features)."""
    if n <= p:
        raise ValueError(
            f"n_samples={n} is too few for regression={regression!r} "
            f"with {d} features: at least {p + 1} samples are needed "
            f"(p={p} regression terms). Add samples or use a lower-order "
            "regression."
        )


def check_covariance_size(n, q, p, regression):
    """Enough samples for the ``q x q`` Sigma2 of a noise-free fit without ridge."""
    if q > n - p:
        raise ValueError(
            f"n_samples={n} is too few to estimate the {q} x {q} response "
            "covariance sigma2_ of a noise-free fit with "
            f"regression={regression!r} (p={p} terms): it needs "
            f"n_samples >= p + q = {p + q}. Add samples, set "
            "response_nugget (e.g. 1e-8), fit fewer responses at once, or "
            "use noise=True."
        )


def warn_at_bounds(kernel, *, noise=None):
    """A ``ConvergenceWarning`` per fitted hyperparameter on a bound.

    As scikit-learn's ``GaussianProcessRegressor``: a value within
    ``numpy.isclose`` of a bound of its (log) search interval may be held
    there by the bound rather than by the data. Fixed hyperparameters are
    not reported.

    Parameters
    ----------
    kernel : sklearn Kernel or None
        The fitted kernel, whose optimised hyperparameters are checked
        (None: none are).
    noise : tuple (responses, values, bounds), default=None
        The fitted noise variances of a noisy fit: the responses' indices
        (in ``y``), their noise variances, shape (q,), and the bounds of
        their search, shape (q, 2), in the same units. A noise variance at
        its lower bound means data that look noise-free; at its upper bound,
        a response that looks like noise alone.
    """
    if noise is not None:
        _warn_noise_at_bounds(*noise)
    if kernel is None:
        return
    theta, bounds = kernel.theta, kernel.bounds
    k = 0
    for hyp in kernel.hyperparameters:
        if hyp.fixed:
            continue
        for dim in range(hyp.n_elements):
            value, (lo, hi) = np.exp(theta[k]), np.exp(bounds[k])
            k += 1
            if np.isclose(theta[k - 1], bounds[k - 1, 0]):
                side, bound = "lower", lo
                meaning = (
                    "the responses hardly vary with this input over its range "
                    "(harmless if it has no effect)"
                )
            elif np.isclose(theta[k - 1], bounds[k - 1, 1]):
                side, bound = "upper", hi
                meaning = (
                    "the training points are too far apart, in this input, to "
                    "inform each other (more points, or an input on another scale)"
                )
            else:
                continue
            warn(
                f"The fitted {hyp.name} of input {dim} ({value:.4g}) is at the "
                f"{side} bound {bound:.4g} of its search: {meaning}. Widen the "
                f"kernel's bounds ({hyp.name}_bounds) or rescale the input if "
                "the likelihood may want a value beyond it.",
                ConvergenceWarning,
            )


def _warn_noise_at_bounds(responses, values, bounds):
    """The noise part of :func:`warn_at_bounds`."""
    low, high = np.exp(LOG_NOISE_BOUNDS)
    for j, value, (lo, hi) in zip(responses, values, bounds, strict=True):
        if np.isclose(np.log(value), np.log(lo)):
            side, bound = "lower", lo
            meaning = (
                "the data look noise-free for this response. Consider "
                "noise=False (with a small response_nugget, e.g. 1e-8, if "
                "responses are exact combinations of others)"
            )
        elif np.isclose(np.log(value), np.log(hi)):
            side, bound = "upper", hi
            meaning = (
                "the response looks like noise alone, with no smooth trend "
                "in the inputs. Check that the inputs drive this response, "
                "or try a rougher kernel"
            )
        else:
            continue
        warn(
            f"The fitted noise variance of response {j} ({value:.4g}) is at "
            f"the {side} bound {bound:.4g} of its search (the bounds are "
            f"{low:.3g} and {high:.3g} times the response's variance): {meaning}.",
            ConvergenceWarning,
        )


# N x N float arrays alive at once in one likelihood and gradient evaluation
# with a DACE kernel (R, its Cholesky factor, R^-1 and its triangular
# copies, the gradient's weight and the kernel's per-dimension temporaries:
# 8 to 11 measured with tracemalloc at N=600, d=4 for Gauss to Spline),
# for the memory check of fit; other kernels add their stacked gradient.
_FIT_ARRAYS = 12


def check_fit_memory(kernel, n, noise):
    """MemoryError before allocating the N x N matrices that do not fit.

    The DACE kernels contract the likelihood gradient one hyperparameter
    at a time (a fixed number of N x N arrays); other kernels return the
    stacked (N, N, n_theta) gradient, copied once more when the log noise
    ratio of a noisy fit (``noise``) is appended.
    """
    n_hyper = kernel.n_dims + int(noise)
    remedy = (
        "Fit on fewer samples (e.g. a space-filling subset of the "
        "simulations) or use a machine with more memory."
    )
    if isinstance(kernel, DACECorrelation):
        n_arrays = _FIT_ARRAYS
        gradient = "its gradient (one hyperparameter at a time)"
    else:
        n_arrays = 2 * n_hyper + _FIT_ARRAYS
        gradient = f"its stacked gradient for {n_hyper} hyperparameter(s)"
        remedy = (
            "Use a kernel of skmba.kernels (e.g. Gauss or Exp, whose "
            f"gradient needs no {n} x {n} x {n_hyper} array), fit on fewer "
            "samples (e.g. a space-filling subset of the simulations) or use "
            "a machine with more memory."
        )
    check_memory(
        8.0 * n * n * n_arrays,
        f"Fitting MultiResponseGP to {n} samples (the {n} x {n} correlation "
        f"matrix, {gradient} and the factorisation workspace)",
        remedy,
    )
