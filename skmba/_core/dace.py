"""The machinery shared by the DACE correlation families of :mod:`skmba.kernels`.

:class:`DACECorrelation` is the base of every family: the product over the
input dimensions of a one-dimensional profile of the scaled distance, its
analytic gradient in the log roughness, and the contraction of that
gradient with a weight matrix (the likelihood's gradient, without the
``(n, n, d)`` array). :class:`ExponentialProfile` is the base of the
families whose profile is ``exp(-zeta)``. The families themselves, their
formulas and conventions are documented in :mod:`skmba.kernels`.

Examples
--------
>>> import numpy as np
>>> from skmba._core.dace import DACECorrelation, leave_one_out_products
>>> from skmba.kernels import Gauss
>>> isinstance(Gauss(), DACECorrelation)
True
>>> leave_one_out_products(np.array([2.0, 0.0, 3.0])).tolist()
[0.0, 6.0, 0.0]
"""

import copy
from functools import cache

import numpy as np
from sklearn.gaussian_process.kernels import (
    Hyperparameter,
    Kernel,
    NormalizedKernelMixin,
    StationaryKernelMixin,
)

from skmba._core.workspace import scratch


def leave_one_out_products(R):
    """Products over the last axis leaving out each entry in turn.

    Returns ``P`` with ``P[..., j] = prod_{k != j} R[..., k]``, computed from
    prefix and suffix cumulative products (no division, so exact zeros of
    compactly supported correlations are handled).
    """
    out = np.ones_like(R)
    if R.shape[-1] > 1:
        np.cumprod(R[..., :-1], axis=-1, out=out[..., 1:])
        suffix = np.cumprod(R[..., :0:-1], axis=-1)[..., ::-1]
        out[..., :-1] *= suffix
    return out


@cache
def _hyperparameter_names(cls):
    """The ``hyperparameter_*`` attributes of a kernel class, in name order
    (the order of scikit-learn's ``Kernel.hyperparameters``)."""
    return tuple(name for name in dir(cls) if name.startswith("hyperparameter_"))


class DACECorrelation(StationaryKernelMixin, NormalizedKernelMixin, Kernel):
    """Shared machinery of the product-form DACE correlation families.

    A family defines the scaled distance ``_zeta(absdiff, roughness)``
    (default ``roughness * |Δ|``, linear in the roughness), the profile
    ``_profile(zeta)`` and its derivative ``_profile_derivative(zeta)``.
    Families with extra hyperparameters add ``_extra_log_gradients``.
    """

    def __init__(self, roughness=1.0, roughness_bounds=(1e-5, 1e5)):
        self.roughness = roughness
        self.roughness_bounds = roughness_bounds

    @property
    def anisotropic(self):
        """bool: whether one roughness per input dimension is used."""
        return bool(np.iterable(self.roughness) and len(self.roughness) > 1)

    @property
    def hyperparameter_roughness(self):
        """Hyperparameter: specification of ``roughness``."""
        if self.anisotropic:
            return Hyperparameter(
                "roughness", "numeric", self.roughness_bounds, len(self.roughness)
            )
        return Hyperparameter("roughness", "numeric", self.roughness_bounds)

    @property
    def roughness_power(self):
        """float: the power of distance the roughness multiplies (1 here).

        The roughness has units ``1 / length**roughness_power``: inputs
        measured in units ``c`` times larger give the same correlation with
        the roughness times ``c**roughness_power``.
        """
        return 1.0

    @property
    def hyperparameters(self):
        """list of Hyperparameter: as scikit-learn's (the ``hyperparameter_*``
        properties in name order), from the class's names found once instead
        of a ``dir()`` of the instance at every call."""
        return [getattr(self, name) for name in _hyperparameter_names(type(self))]

    def clone_with_theta(self, theta):
        """A copy with the hyperparameters ``exp(theta)``, as scikit-learn's.

        The same kernel as ``sklearn.base.clone`` followed by setting
        ``theta`` (the same values, to the bit), without the clone's
        parameter inspection, which likelihood searches would pay at every
        evaluation: a shallow copy whose arrays and containers are copied.
        """
        theta = np.asarray(theta)
        new = copy.copy(self)
        for name, value in vars(new).items():
            if isinstance(value, np.ndarray):
                setattr(new, name, value.copy())
            elif isinstance(value, list | dict | set):
                setattr(new, name, copy.deepcopy(value))
        i = 0
        for hyperparameter in self.hyperparameters:
            if hyperparameter.fixed:
                continue
            k = hyperparameter.n_elements
            value = np.exp(theta[i : i + k]) if k > 1 else np.exp(theta[i])
            setattr(new, hyperparameter.name, value)
            i += k
        if i != len(theta):
            raise ValueError(
                f"theta has {len(theta)} entries; this kernel has {i} free "
                "log hyperparameters."
            )
        return new

    # -- family hooks -------------------------------------------------------
    #: True for profiles exp(-ζ), whose product and gradient have a fast form.
    _exponential = False

    def _validate_params(self):
        """Check family-specific parameters at call time (default: none)."""

    def _zeta(self, absdiff, roughness, out=None):
        """Scaled distance; must be proportional to ``roughness``.

        ``out`` (e.g. ``absdiff`` itself) receives it; the values are those
        computed without it.
        """
        return np.multiply(absdiff, roughness, out=out)

    @staticmethod
    def _profile(zeta):  # pragma: no cover - abstract
        raise NotImplementedError

    @staticmethod
    def _profile_derivative(zeta):  # pragma: no cover - abstract
        raise NotImplementedError

    def _extra_log_gradients(self, absdiff, zeta, dprofile):
        """Per-dimension log-derivatives of ``R_j`` w.r.t. other parameters.

        Returns a dict mapping a hyperparameter name to an array of shape
        ``(n, n, d)`` holding ``θ ∂R_j/∂θ``.
        """
        return {}

    # -- shared machinery ---------------------------------------------------
    def _check_roughness(self, n_features):
        roughness = np.squeeze(np.asarray(self.roughness, dtype=float))
        if roughness.ndim > 1:
            raise ValueError(
                "roughness must be a scalar or a 1-D array, got an array of "
                f"shape {np.shape(self.roughness)}."
            )
        if roughness.ndim == 1 and roughness.shape[0] != n_features:
            raise ValueError(
                f"roughness has {roughness.shape[0]} elements but X has "
                f"{n_features} columns; pass a scalar roughness (isotropic) or "
                "one value per column of X (anisotropic)."
            )
        if not np.all(np.isfinite(roughness)) or np.any(roughness <= 0):
            raise ValueError(
                f"roughness must be finite and positive, got {self.roughness!r}."
            )
        return roughness

    def __call__(self, X, Y=None, eval_gradient=False):
        """Return the correlation matrix k(X, Y) and optionally its gradient.

        Parameters
        ----------
        X : array-like of shape (n_samples_X, n_features)
            Left argument of the returned kernel k(X, Y).
        Y : array-like of shape (n_samples_Y, n_features), default=None
            Right argument of the returned kernel k(X, Y). If None, k(X, X)
            is evaluated instead.
        eval_gradient : bool, default=False
            Whether to also return the gradient with respect to the log of
            the non-fixed hyperparameters. Only supported when Y is None.

        Returns
        -------
        K : ndarray of shape (n_samples_X, n_samples_Y)
            Correlation matrix k(X, Y).
        K_gradient : ndarray of shape (n_samples_X, n_samples_X, n_dims)
            Analytic gradient of k(X, X) with respect to ``theta`` (log of
            the non-fixed hyperparameters, in the order of
            ``hyperparameters``). Only returned when ``eval_gradient`` is
            True.
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if Y is None:
            Y = X
        else:
            if eval_gradient:
                raise ValueError("Gradient can only be evaluated when Y is None.")
            Y = np.atleast_2d(np.asarray(Y, dtype=float))
            if Y.shape[1] != X.shape[1]:
                raise ValueError(
                    f"X and Y must have the same number of columns, got "
                    f"{X.shape[1]} and {Y.shape[1]}."
                )
        if not eval_gradient:
            return self._correlation(X, Y)
        absdiff = np.abs(X[:, np.newaxis, :] - Y[np.newaxis, :, :])
        return self._from_differences(absdiff, eval_gradient)

    def _dimension(self, X, Y, j, roughness, keep_absdiff=True):
        """``|Δ_j|`` and ``ζ_j`` of input dimension ``j``, shape (n, m).

        Without ``keep_absdiff``, ``|Δ_j|`` is built in the thread's
        :func:`~skmba._core.workspace.scratch` buffer, ``ζ_j`` overwrites it
        where the profile allows (one n x m array less at the peak of a large
        likelihood), and None is returned in its place: the caller uses
        ``ζ_j`` up before the next dimension.
        """
        # Not kept: the thread's scratch buffer, which the caller's next
        # dimension reuses (a fresh n x m array per dimension made glibc
        # fault its pages in again, docs/internals.rst, skmba._core.workspace).
        out = None if keep_absdiff else scratch((len(X), len(Y)))
        absdiff = np.subtract(X[:, j, np.newaxis], Y[np.newaxis, :, j], out=out)
        np.abs(absdiff, out=absdiff)
        scale = roughness[j] if roughness.ndim else roughness
        if keep_absdiff:
            return absdiff, self._zeta(absdiff, scale)
        return None, self._zeta(absdiff, scale, out=absdiff)

    def _correlation(self, X, Y):
        """``k(X, Y)`` one input dimension at a time.

        The same values as the stacked evaluation of
        :meth:`_from_differences` (the same operations in the same order for
        fewer than 8 inputs), with a few (n, m) temporaries instead of
        (n, m, d) arrays: what keeps large likelihoods and batched
        predictions within memory.
        """
        self._validate_params()
        roughness = self._check_roughness(X.shape[1])
        K = (
            np.zeros((len(X), len(Y)))
            if self._exponential
            else np.ones((len(X), len(Y)))
        )
        for j in range(X.shape[1]):
            _, zeta = self._dimension(X, Y, j, roughness, keep_absdiff=False)
            if self._exponential:
                K += zeta
            else:
                K *= self._profile(zeta)
        if self._exponential:
            np.negative(K, out=K)
            np.exp(K, out=K)
        return K

    def _others(self, X, j, roughness, K, R_j, dprofile):
        """``prod_{k != j} R_k`` from the product ``K``: ``K / R_j``.

        Where ``R_j`` is exactly zero but its derivative is not (rounding at
        the edge of a compact support) the product is recomputed on those
        entries, so no gradient is lost to the division.
        """
        others = np.zeros_like(K)
        np.divide(K, R_j, out=others, where=R_j != 0)
        rows, cols = np.nonzero((R_j == 0) & (dprofile != 0))
        if rows.size:
            product = np.ones(rows.size)
            for k in range(X.shape[1]):
                if k != j:
                    scale = roughness[k] if roughness.ndim else roughness
                    diff = np.abs(X[rows, k] - X[cols, k])
                    product *= self._profile(self._zeta(diff, scale))
            others[rows, cols] = product
        return others

    def _weighted_log_gradient(self, X, K, weight):
        """``[sum(weight * dK/dtheta_k) for k]``, one input dimension at a time.

        The contraction of the stacked gradient of ``self(X,
        eval_gradient=True)`` with a symmetric ``weight`` (the trace terms of
        likelihood gradients) without its (n, n, n_dims) array: with the
        product form, ``dK/dlog omega_j = (prod_{k != j} R_k) ζ_j f'(ζ_j)``,
        which is ``-K ζ_j`` for the exponential profiles, so only a few n x n
        temporaries are alive at a time. ``K`` is ``self(X)``; its diagonal is
        not used (``ζ = 0`` there), so it may carry a nugget.

        Returns
        -------
        ndarray of shape (n_dims,)
            In the order of ``theta``.
        """
        self._validate_params()
        free = [hp.name for hp in self.hyperparameters if not hp.fixed]
        d = X.shape[1]
        roughness = self._check_roughness(d)
        totals = {name: np.zeros(d) for name in free}
        extra = any(name != "roughness" for name in free)
        if self._exponential:
            scaled = weight * K  # f' = -f: the sign goes into the weight
            np.negative(scaled, out=scaled)
            dprofile = 1.0
        for j in range(d if free else 0):
            # |Δ_j| is needed after ζ_j only for the extra hyperparameters.
            absdiff, zeta = self._dimension(X, X, j, roughness, keep_absdiff=extra)
            if self._exponential:
                slope = zeta
            else:
                dprofile = self._profile_derivative(zeta)
                scaled = self._others(X, j, roughness, K, self._profile(zeta), dprofile)
                scaled *= weight
                slope = (
                    zeta * dprofile
                    if extra
                    else np.multiply(dprofile, zeta, out=dprofile)
                )
            if "roughness" in totals:
                totals["roughness"][j] = np.vdot(scaled, slope)
            if extra:
                for name, value in self._extra_log_gradients(
                    absdiff, zeta, dprofile
                ).items():
                    if name in totals:
                        totals[name][j] = np.vdot(scaled, value)
            # Free this dimension's n x n arrays before the next is made.
            del absdiff, zeta, slope
            if not self._exponential:
                del scaled, dprofile
        parts = [
            totals[name]
            if name == "roughness" and self.anisotropic
            else totals[name].sum(keepdims=True)
            for name in free
        ]
        return np.concatenate(parts) if parts else np.empty(0)

    def _from_differences(self, absdiff, eval_gradient=False):
        """The correlation (and gradient) from ``|X_i - Y_j|`` per dimension.

        ``absdiff`` has shape (n, m, d) and is not modified, so a caller that
        evaluates many hyperparameters on the same points (likelihood
        optimisation) computes it once.
        """
        self._validate_params()
        roughness = self._check_roughness(absdiff.shape[2])
        zeta = self._zeta(absdiff, roughness)
        if self._exponential:
            # prod_j exp(-ζ_j) = exp(-sum_j ζ_j): one exp instead of d, and
            # prod_{k≠j} R_k · R_j'(ζ_j) = -K, so no leave-one-out products.
            K = zeta.sum(axis=2)
            np.negative(K, out=K)
            np.exp(K, out=K)
        else:
            R = self._profile(zeta)
            K = np.prod(R, axis=2)
        if not eval_gradient:
            return K

        n = absdiff.shape[0]
        free = [hp for hp in self.hyperparameters if not hp.fixed]
        if not free:
            return K, np.empty((n, n, 0))

        # zeta is proportional to roughness, so ω ∂R_j/∂ω_j = ζ_j f'(ζ_j).
        if self._exponential:
            # f' = -f: fold the sign into the product and skip a temporary.
            others, dprofile = -K[..., np.newaxis], 1.0
            per_dim = {"roughness": zeta}
        else:
            others = leave_one_out_products(R)
            dprofile = self._profile_derivative(zeta)
            per_dim = {"roughness": zeta * dprofile}
        per_dim.update(self._extra_log_gradients(absdiff, zeta, dprofile))

        slices = []
        for hp in free:
            grad = others * per_dim[hp.name]
            # A scalar hyperparameter shared by all dimensions: sum rule.
            if hp.name != "roughness" or not self.anisotropic:
                grad = grad.sum(axis=2, keepdims=True)
            slices.append(grad)
        if len(slices) == 1:
            return K, slices[0]
        return K, np.concatenate(slices, axis=2)

    def __repr__(self):
        name = self.__class__.__name__
        if self.anisotropic:
            values = ", ".join(f"{w:.3g}" for w in self.roughness)
            return f"{name}(roughness=[{values}])"
        return f"{name}(roughness={np.ravel(self.roughness)[0]:.3g})"


class ExponentialProfile(DACECorrelation):
    """Families with profile ``exp(-ζ)``; they differ only in ``ζ``."""

    _exponential = True

    @staticmethod
    def _profile(zeta):
        return np.exp(-zeta)

    @staticmethod
    def _profile_derivative(zeta):
        return -np.exp(-zeta)
