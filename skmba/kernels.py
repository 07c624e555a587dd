r"""DACE correlation functions as scikit-learn kernels.

The seven correlation families of the DACE toolbox (thesis Table 3.2,
Eq. 3.6), as subclasses of :class:`sklearn.gaussian_process.kernels.Kernel`.
Each is a product over the ``d`` input dimensions of a one-dimensional
correlation of :math:`\Delta_j = x_j - x'_j`, with one *roughness*
:math:`\omega_j > 0` per input dimension (anisotropic) or a single shared
one (isotropic). A larger roughness means a faster decay of the
correlation, i.e. a rougher process.

- :class:`Exp`, :class:`GeneralizedExp` and :class:`Gauss`: exponential
  profiles (common code in :class:`skmba._core.dace.ExponentialProfile`);
- :class:`Linear`, :class:`Spherical`, :class:`Cubic` and :class:`Spline`:
  compact support, the correlation is exactly zero once
  :math:`\omega_j |\Delta_j| \ge 1` (common code in
  :class:`skmba._core.dace.DACECorrelation`);
- :func:`check_correlation`: that a kernel, including products with
  scikit-learn kernels, has the unit diagonal of a correlation, as
  :class:`~skmba.MultiResponseGP` and the calibrators require.

All kernels are normalised (unit diagonal), so they are correlations: the
process variances are estimated separately (``sigma2_`` of
``MultiResponseGP``). The formulas, the smoothness of each family and when
to use it are in the User Guide (:ref:`correlation-families`); ``Cubic``
is not positive definite, and is kept for compatibility with DACE. Why the
others are, their relation to scikit-learn's length scales and the
conventions of their gradients: docs/internals.rst, section skmba.kernels.
"""

import numpy as np
from sklearn.gaussian_process.kernels import Hyperparameter, Kernel

from skmba._core.dace import DACECorrelation, ExponentialProfile

__all__ = [
    "Cubic",
    "Exp",
    "Gauss",
    "GeneralizedExp",
    "Linear",
    "Spherical",
    "Spline",
    "check_correlation",
]


class Exp(ExponentialProfile):
    """Exponential correlation ``prod_j exp(-ω_j |Δ_j|)``.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length). A scalar gives an isotropic kernel, an
        array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Exp
    >>> np.round(Exp(roughness=2.0)(np.array([[0.0], [0.5]])), 4)
    array([[1.    , 0.3679],
           [0.3679, 1.    ]])
    """


class GeneralizedExp(ExponentialProfile):
    """Generalised exponential correlation ``prod_j exp(-ω_j |Δ_j|^p)``.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length^p). A scalar gives an isotropic kernel,
        an array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.
    power : float, default=1.0
        Exponent p, shared by all dimensions; must satisfy 0 < p <= 2
        (checked when the kernel is evaluated). p = 1 gives :class:`Exp`,
        p = 2 gives :class:`Gauss`.
    power_bounds : pair of floats > 0 or "fixed", default=(1e-2, 2.0)
        Bounds on ``power`` for hyperparameter optimisation.

    Notes
    -----
    The gradient with respect to ``log p`` is
    ``p ∂R_j/∂p = -R_j ω_j |Δ_j|^p p log|Δ_j|``, taken as zero at Δ_j = 0
    (the limit, using 0 log 0 = 0).

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import GeneralizedExp
    >>> kernel = GeneralizedExp(roughness=1.0, power=1.5)
    >>> kernel
    GeneralizedExp(roughness=1, power=1.5)
    >>> np.round(kernel(np.array([[0.0], [2.0]])), 4)
    array([[1.    , 0.0591],
           [0.0591, 1.    ]])
    """

    def __init__(
        self,
        roughness=1.0,
        roughness_bounds=(1e-5, 1e5),
        power=1.0,
        power_bounds=(1e-2, 2.0),
    ):
        self.roughness = roughness
        self.roughness_bounds = roughness_bounds
        self.power = power
        self.power_bounds = power_bounds

    @property
    def hyperparameter_power(self):
        """Hyperparameter: specification of ``power``."""
        return Hyperparameter("power", "numeric", self.power_bounds)

    def _validate_params(self):
        power = np.asarray(self.power, dtype=float)
        if power.size != 1 or not (0.0 < float(power.ravel()[0]) <= 2.0):
            raise ValueError(
                f"power must be a scalar with 0 < power <= 2, got {self.power!r}."
            )

    def _power(self):
        return float(np.ravel(self.power)[0])

    @property
    def roughness_power(self):
        """float: ``power``, the power of distance the roughness multiplies."""
        return self._power()

    def _zeta(self, absdiff, roughness, out=None):
        # ``out`` is not used: numpy's ``**`` takes fast paths (square,
        # sqrt) that ``np.power(..., out=)`` may not, and the values must
        # not depend on the memory saving.
        return roughness * absdiff ** self._power()

    def _extra_log_gradients(self, absdiff, zeta, dprofile):
        log_abs = np.log(absdiff, out=np.zeros_like(absdiff), where=absdiff > 0)
        return {"power": dprofile * zeta * log_abs * self._power()}

    def __repr__(self):
        base = super().__repr__()
        return f"{base[:-1]}, power={self._power():.3g})"


class Gauss(ExponentialProfile):
    """Gaussian correlation ``prod_j exp(-ω_j Δ_j²)``.

    Identical to scikit-learn's ``RBF(length_scale=1/sqrt(2ω))``.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length²). A scalar gives an isotropic kernel, an
        array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Gauss
    >>> np.round(Gauss(roughness=2.0)(np.array([[0.0], [0.5]])), 4)
    array([[1.    , 0.6065],
           [0.6065, 1.    ]])
    >>> Gauss(roughness=[1, 2])
    Gauss(roughness=[1, 2])
    """

    @property
    def roughness_power(self):
        """float: 2, the roughness multiplies the squared distance."""
        return 2.0

    def _zeta(self, absdiff, roughness, out=None):
        zeta = np.square(absdiff, out=out)
        zeta *= roughness
        return zeta


class Linear(DACECorrelation):
    """Linear correlation ``prod_j max(0, 1 - ω_j |Δ_j|)``.

    Compactly supported.  At the edge of the support (``ω_j |Δ_j| = 1``) the
    gradient uses the one-sided derivative from outside the support, i.e.
    zero.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length). A scalar gives an isotropic kernel, an
        array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Linear
    >>> np.round(Linear(roughness=1.0)(np.array([[0.0], [0.25], [2.0]])), 4)
    array([[1.  , 0.75, 0.  ],
           [0.75, 1.  , 0.  ],
           [0.  , 0.  , 1.  ]])
    """

    @staticmethod
    def _profile(zeta):
        return np.maximum(0.0, 1.0 - zeta)

    @staticmethod
    def _profile_derivative(zeta):
        return np.where(zeta < 1.0, -1.0, 0.0)


class Spherical(DACECorrelation):
    """Spherical correlation ``prod_j (1 - 1.5 ζ_j + 0.5 ζ_j³)``.

    With ``ζ_j = min(1, ω_j |Δ_j|)``; compactly supported.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length). A scalar gives an isotropic kernel, an
        array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Spherical
    >>> np.round(Spherical(roughness=1.0)(np.array([[0.0], [0.5]])), 4)
    array([[1.    , 0.3125],
           [0.3125, 1.    ]])
    """

    @staticmethod
    def _profile(zeta):
        z = np.minimum(1.0, zeta)
        return 1.0 - 1.5 * z + 0.5 * z**3

    @staticmethod
    def _profile_derivative(zeta):
        return np.where(zeta < 1.0, 1.5 * zeta**2 - 1.5, 0.0)


class Cubic(DACECorrelation):
    """Cubic correlation ``prod_j (1 - 3 ζ_j² + 2 ζ_j³)``.

    With ``ζ_j = min(1, ω_j |Δ_j|)``; compactly supported.  Unlike the other
    families this profile is not positive definite, not even in one
    dimension (its Fourier transform changes sign), so correlation matrices
    on dense point sets can have small negative eigenvalues; it is kept for
    compatibility with DACE and should be used with a nugget.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length). A scalar gives an isotropic kernel, an
        array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Cubic
    >>> np.round(Cubic(roughness=1.0)(np.array([[0.0], [0.5]])), 4)
    array([[1. , 0.5],
           [0.5, 1. ]])
    """

    @staticmethod
    def _profile(zeta):
        z = np.minimum(1.0, zeta)
        return 1.0 - 3.0 * z**2 + 2.0 * z**3

    @staticmethod
    def _profile_derivative(zeta):
        return np.where(zeta < 1.0, 6.0 * zeta**2 - 6.0 * zeta, 0.0)


class Spline(DACECorrelation):
    """Cubic spline correlation ``prod_j ς(ω_j |Δ_j|)`` (thesis Eq. 3.6).

    ς(ζ) = 1 - 15ζ² + 30ζ³ for ζ <= 0.2, 1.25 (1 - ζ)³ for 0.2 < ζ < 1 and
    0 for ζ >= 1; value and first derivative are continuous everywhere.
    Compactly supported and positive definite.

    Parameters
    ----------
    roughness : float or array-like of shape (n_features,), default=1.0
        Roughness ω (units 1/length). A scalar gives an isotropic kernel, an
        array one roughness per input dimension.
    roughness_bounds : pair of floats > 0 or "fixed", default=(1e-5, 1e5)
        Bounds on ``roughness`` for hyperparameter optimisation.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.kernels import Spline
    >>> np.round(Spline(roughness=1.0)(np.array([[0.0], [0.6]])), 4)
    array([[1.  , 0.08],
           [0.08, 1.  ]])
    """

    @staticmethod
    def _profile(zeta):
        z = np.minimum(zeta, 0.2)  # the inner piece only; no overflow of z**3
        inner = 1.0 - 15.0 * z**2 + 30.0 * z**3
        outer = 1.25 * np.clip(1.0 - zeta, 0.0, None) ** 3
        return np.where(zeta <= 0.2, inner, outer)

    @staticmethod
    def _profile_derivative(zeta):
        z = np.minimum(zeta, 0.2)
        inner = 90.0 * z**2 - 30.0 * z
        outer = -3.75 * np.clip(1.0 - zeta, 0.0, None) ** 2
        return np.where(zeta <= 0.2, inner, outer)


def check_correlation(kernel, X, name="kernel"):
    """Check that ``kernel`` is a correlation (unit diagonal) on ``X``.

    ``MultiResponseGP`` estimates the process variances itself (``sigma2_``)
    and per-response noise through ``noise=True``, so its kernel must be a
    pure correlation.  Scikit-learn's ``RBF``, ``Matern``,
    ``RationalQuadratic``, ``ExpSineSquared``, the DACE families of this
    module and products of correlations pass; kernels containing
    ``ConstantKernel`` or ``WhiteKernel`` terms do not.

    Parameters
    ----------
    kernel : sklearn.gaussian_process.kernels.Kernel
        Kernel to check.
    X : array-like of shape (n_samples, n_features)
        Points at which the diagonal is evaluated.
    name : str, default="kernel"
        The parameter's name in the messages.

    Returns
    -------
    None

    Raises
    ------
    TypeError
        If ``kernel`` is not a scikit-learn ``Kernel`` instance.
    ValueError
        If ``kernel.diag(X)`` differs from one by more than 1e-8.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.gaussian_process.kernels import RBF, ConstantKernel
    >>> from skmba.kernels import Gauss, check_correlation
    >>> X = np.array([[0.0, 1.0], [2.0, 3.0]])
    >>> check_correlation(Gauss() * RBF(), X)
    >>> check_correlation(ConstantKernel(2.0) * RBF(), X)
    Traceback (most recent call last):
    ...
    ValueError: The kernel must be a correlation with unit diagonal...
    """
    if not isinstance(kernel, Kernel):
        raise TypeError(
            f"{name} must be an instance of sklearn.gaussian_process.kernels."
            f"Kernel, got {type(kernel).__name__}."
        )
    X = np.atleast_2d(np.asarray(X, dtype=float))
    diag = np.asarray(kernel.diag(X), dtype=float)
    if diag.size and not np.all(np.abs(diag - 1.0) <= 1e-8):
        raise ValueError(
            f"The {name} must be a correlation with unit diagonal "
            f"(kernel.diag(X) == 1), but {kernel!r} has diagonal values in "
            f"[{np.min(diag):.6g}, {np.max(diag):.6g}]. Remove ConstantKernel "
            "or WhiteKernel factors/terms (e.g. pass RBF() instead of "
            "ConstantKernel(2.0) * RBF()): skmba estimates the variances "
            "itself (MultiResponseGP's sigma2_, the calibrator's discrepancy "
            "covariance) and the per-response noise (noise=True)."
        )
