"""The default prior of the module-2 hyperparameters (discrepancy and noise).

The prior is stated in the terms of the field data (:class:`PriorUnits`):
each design variable centred and scaled by its standard deviation over the
distinct field inputs, each response scaled by the spread of the model's
response over the field inputs and the prior of theta. There, the
discrepancy ``delta ~ GP(H_d beta_d, Sigma_d ⊗ R_d(omega))`` and the noise
``eps ~ N(0, Lambda)`` have the weakly informative prior

* ``sd_j = sqrt(Sigma_d[j, j])``: half-normal with scale ``sd_scale`` (0.5:
  a discrepancy as large as the model's whole spread over the field
  inputs and the prior has prior probability 4.6 %), independently per
  response;
* the correlation ``Sigma_d[i, j] / (sd_i sd_j)``: LKJ(``eta``) (Lewandowski,
  Kurowicka & Joe 2009), ``eta = 2`` leaning gently towards independent
  discrepancies;
* the roughness ``omega``: log-uniform on thesis Table 6.2's range, 0.1 to
  9 per design variable (any other kernel hyperparameter: log-uniform within
  the kernel's bounds, in module 2's units);
* the noise variance ``Lambda[j, j]``: log-uniform from 1e-6 to 1;
* ``beta_d``: flat (integrated out, restricted likelihood).

Module 2 works in the simulations' standardised units; :class:`PriorUnits`
holds the ratios that carry the prior there, so that the prior, and the
result, do not change when only the simulation design does. :class:`Hyperprior`
holds these numbers once; module 2
(:mod:`skmba.calibration._module2_posterior`) uses its log density, the
validation suite its draws.

Examples
--------
>>> import numpy as np
>>> prior = Hyperprior()
>>> draw = prior.rvs(d=1, q=2, random_state=0)
>>> sorted(draw)
['correlation', 'noise', 'roughness', 'sd']
>>> bool(np.allclose(np.diag(draw["correlation"]), 1.0))
True
"""

from dataclasses import dataclass, replace

import numpy as np
from scipy import special, stats

from skmba._core.validation import seed_sequence

#: Thesis Table 6.2's roughness range, here the support of a log-uniform prior.
ROUGHNESS_RANGE = (0.1, 9.0)
#: The keys of ``discrepancy_prior`` with the default treatment.
HYPERPRIOR_KEYS = ("sd_scale", "correlation_eta", "roughness", "noise")


@dataclass(frozen=True)
class PriorUnits:
    """The field data's units of the hyperprior, relative to module 2's.

    Module 2 standardises inputs and responses by the simulations; the
    prior is stated with inputs scaled by the field inputs' spread and
    responses by the model's spread at the field inputs. A distance in
    module 2's units times ``input_ratio`` is one in the prior's; a
    response in the prior's units times ``response_ratio`` is one in
    module 2's.

    Parameters
    ----------
    input_ratio : tuple of float, length d
        Per design variable, the simulations' standard deviation over the
        field inputs' (1 where the field inputs do not vary).
    response_ratio : tuple of float, length q
        Per response, the model's spread over the field inputs and the
        prior of theta over the simulations' standard deviation.

    Examples
    --------
    >>> units = PriorUnits(input_ratio=(2.0,), response_ratio=(0.5, 1.0))
    >>> units.roughness(0.1, 2.0).tolist()  # Gauss: 1 / length**2
    [0.4]
    """

    input_ratio: tuple
    response_ratio: tuple

    def __post_init__(self):
        for name in ("input_ratio", "response_ratio"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.ndim != 1 or not np.all(np.isfinite(value) & (value > 0)):
                raise ValueError(f"{name} must be positive and finite, got {value}.")
            object.__setattr__(self, name, tuple(value.tolist()))

    def roughness(self, value, power):
        """A roughness of the prior's units in module 2's, per input (d,)."""
        return np.asarray(value, dtype=float) * np.asarray(self.input_ratio) ** power

    def response(self, value, power=1):
        """A response quantity of the prior's units in module 2's, per
        response: a mean (``power=1``) or a variance (``power=2``)."""
        ratio = np.asarray(self.response_ratio)
        return np.asarray(value, dtype=float) * ratio**power

    def restrict(self, responses):
        """The units of some responses only."""
        ratio = np.asarray(self.response_ratio)[list(responses)]
        return PriorUnits(self.input_ratio, tuple(ratio.tolist()))


@dataclass(frozen=True)
class Hyperprior:
    """Prior of the discrepancy and noise hyperparameters.

    Parameters
    ----------
    sd_scale : float or array of shape (q,), default=0.5
        Scale of the half-normal prior of each response's discrepancy
        standard deviation; one per response to say that some responses'
        model error is known to be smaller (thesis section 6.3 trusts the
        tip rotation).
    correlation_eta : float, default=2.0
        Shape of the LKJ prior of the discrepancy correlation between
        responses (1: uniform over correlation matrices).
    roughness : tuple or None, default=(0.1, 9.0)
        Range of the log-uniform prior of the discrepancy roughness; None:
        log-uniform within the discrepancy kernel's own ``roughness_bounds``
        (draws of the prior, :meth:`rvs`, then need a range).
    noise : tuple, default=(1e-6, 1.0)
        Range of the log-uniform prior of the noise variances.
    units : PriorUnits, default=None
        The field data's units the numbers above are stated in, relative
        to module 2's standardised units (:meth:`in_units`); None: module
        2's units themselves.
    """

    sd_scale: float = 0.5
    correlation_eta: float = 2.0
    roughness: tuple = ROUGHNESS_RANGE
    noise: tuple = (1e-6, 1.0)
    units: PriorUnits = None

    def in_units(self, units):
        """This prior, stated in ``units`` (a :class:`PriorUnits`)."""
        return replace(self, units=units)

    def restrict(self, responses):
        """The prior of some responses (columns) only."""
        responses = list(responses)
        scale = np.asarray(self.sd_scale, dtype=float)
        return replace(
            self,
            sd_scale=scale[responses] if scale.ndim else self.sd_scale,
            units=None if self.units is None else self.units.restrict(responses),
        )

    @classmethod
    def from_spec(cls, spec, name="discrepancy_prior"):
        """The prior of a ``discrepancy_prior`` dict (None: the defaults)."""
        spec = {} if spec is None else spec
        if not isinstance(spec, dict):
            raise TypeError(
                f"{name} must be None or a dict with keys among "
                f"{sorted(HYPERPRIOR_KEYS)}, got {type(spec).__name__}."
            )
        unknown = set(spec) - set(HYPERPRIOR_KEYS)
        if unknown:
            raise ValueError(
                f"{name} has unknown keys {sorted(unknown)} for "
                "discrepancy_uncertainty='propagate'; use keys among "
                f"{sorted(HYPERPRIOR_KEYS)} (the ranges 'variance' belong to "
                "discrepancy_uncertainty='plug-in')."
            )
        prior = cls(**spec)
        scale = np.asarray(prior.sd_scale, dtype=float)
        if scale.ndim > 1 or not (np.all(np.isfinite(scale)) and np.all(scale > 0)):
            raise ValueError(
                f"{name}['sd_scale'] must be a positive number or a 1-D array of "
                f"them (one per response), got {prior.sd_scale!r}."
            )
        eta = prior.correlation_eta
        if not (np.isscalar(eta) and np.isfinite(eta) and eta > 0):
            raise ValueError(f"{name}['correlation_eta'] must be a positive number.")
        for key in ("roughness", "noise"):
            value = getattr(prior, key)
            if key == "roughness" and value is None:
                continue  # the kernel's own bounds
            bounds = np.asarray(value, dtype=float).reshape(-1)
            if not (bounds.size == 2 and 0 < bounds[0] < bounds[1] < np.inf):
                raise ValueError(
                    f"{name}[{key!r}] must be a range (low, high) with "
                    f"0 < low < high, got {getattr(prior, key)!r}."
                )
        return prior

    def scales(self, q, name="discrepancy_prior"):
        """``sd_scale`` for ``q`` responses (checked), in module 2's units."""
        scale = np.asarray(self.sd_scale, dtype=float)
        if scale.ndim == 1 and scale.size != q:
            raise ValueError(
                f"{name}['sd_scale'] has {scale.size} values for {q} responses; "
                "give one per response or a single number."
            )
        scale = np.broadcast_to(scale, (q,))
        return scale if self.units is None else self.units.response(scale)

    def noise_bounds(self, q):
        """The noise variances' range per response (q, 2), module 2's units."""
        bounds = np.tile(np.asarray(self.noise, dtype=float), (q, 1))
        return bounds if self.units is None else self.units.response(bounds.T, 2).T

    def roughness_bounds(self, d, power=2.0):
        """The roughness range per input, ``(low (d,), high (d,))`` in module
        2's units for a kernel whose roughness multiplies ``distance**power``
        (:attr:`skmba.kernels.Gauss.roughness_power`); None when this prior
        has no range (the kernel's own bounds)."""
        if self.roughness is None:
            return None
        lo, hi = (np.full(d, float(v)) for v in self.roughness)
        if self.units is None:
            return lo, hi
        return self.units.roughness(lo, power), self.units.roughness(hi, power)

    # -------------------------------------------------- log densities
    def log_sd(self, log_sd):
        """Log density of ``log sd`` (half-normal on ``sd``, with Jacobian),
        and its derivative."""
        scale2 = self.scales(np.size(log_sd)) ** 2
        sd2 = np.exp(2.0 * log_sd)
        value = -0.5 * sd2 / scale2 + log_sd
        return float(np.sum(value)), 1.0 - sd2 / scale2

    def log_correlation(self, z, q):
        """Log density of the correlation factor's free entries ``z``.

        The factor has rows ``w_i / |w_i|``, ``w_i = (z_i1, ..., 1)``
        (:class:`~skmba.calibration._module2_plug_in.DiscrepancyFit`); LKJ(eta) on the
        correlation and the Jacobian of this map give ``-(q + 2 eta - 1) / 2
        sum_i log |w_i|^2``. Returns the value and its gradient.
        """
        rows, _ = np.tril_indices(q, -1)
        norms2 = 1.0 + np.bincount(rows, weights=z**2, minlength=q)
        c = 0.5 * (q + 2.0 * self.correlation_eta - 1.0)
        return float(-c * np.sum(np.log(norms2))), -2.0 * c * z / norms2[rows]

    def log_correlation_normalised(self, z, q):
        """:meth:`log_correlation` with its normalising constant.

        The density factorises over the rows of the factor: row ``i`` (with
        ``m = i - 1`` free entries) has ``(1 + |z_i|^2)^-c``, ``c = (q + 2
        eta - 1) / 2``, whose integral over ``R^m`` is ``pi^(m/2)
        Gamma(c - m/2) / Gamma(c)``.
        """
        value, _ = self.log_correlation(z, q)
        c = 0.5 * (q + 2.0 * self.correlation_eta - 1.0)
        m = np.arange(q)
        log_const = 0.5 * m * np.log(np.pi) + special.gammaln(c - 0.5 * m)
        return value - float(np.sum(log_const - special.gammaln(c)))

    def log_sd_normalised(self, log_sd):
        """:meth:`log_sd` with the half-normal's normalising constant."""
        value, _ = self.log_sd(log_sd)
        scale = self.scales(np.size(log_sd))
        return value + float(np.sum(np.log(np.sqrt(2.0 / np.pi) / scale)))

    # -------------------------------------------------- draws
    def rvs(self, d, q, random_state=None, roughness_bounds=None, power=2.0):
        """One draw of the hyperparameters (module 2's units).

        Returns a dict: ``roughness`` (d,), ``sd`` (q,), ``correlation``
        (q, q) and ``noise`` (q,) variances. ``roughness_bounds`` (``(low,
        high)``, each a number or (d,)) is the range of the roughness when
        this prior's ``roughness`` is None (the kernel's own bounds);
        ``power`` the kernel's :attr:`~skmba.kernels.Gauss.roughness_power`.
        """
        rng = np.random.default_rng(seed_sequence(random_state))
        log_uniform = stats.loguniform
        bounds = self.roughness_bounds(d, power) or roughness_bounds
        if bounds is None:
            raise ValueError(
                "discrepancy_prior['roughness'] is None (the kernel's own bounds): "
                "drawing the prior needs the kernel's roughness_bounds."
            )
        lo, hi = (np.broadcast_to(np.asarray(b, dtype=float), (d,)) for b in bounds)
        noise = self.noise_bounds(q)
        return {
            "roughness": log_uniform.rvs(lo, hi, size=d, random_state=rng),
            "sd": np.abs(rng.normal(0.0, self.scales(q), q)),
            "correlation": lkj_correlation(q, self.correlation_eta, rng),
            "noise": log_uniform.rvs(noise[:, 0], noise[:, 1], random_state=rng),
        }

    def sd_quantile(self, level, q=1):
        """The ``level`` quantile of the prior of each of ``q`` discrepancy sds."""
        return stats.halfnorm.ppf(level, scale=self.scales(q))


def lkj_correlation(q, eta, rng):
    """A correlation matrix from LKJ(``eta``), by the C-vine method.

    Partial correlations of the vine are independent, those at level ``k``
    (0-based) ``2 Beta(b_k, b_k) - 1`` with ``b_k = eta + (q - 2 - k) / 2``
    (Lewandowski, Kurowicka & Joe 2009, section 2.4); the marginal of each
    correlation is then ``2 Beta(eta - 1 + q / 2) - 1``, which the tests
    check.

    Examples
    --------
    >>> C = lkj_correlation(3, 2.0, np.random.default_rng(0))
    >>> bool(np.all(np.linalg.eigvalsh(C) > 0)), np.diag(C).tolist()
    (True, [1.0, 1.0, 1.0])
    """
    partial = np.zeros((q, q))
    C = np.eye(q)
    for k in range(q - 1):
        b = eta + 0.5 * (q - 2 - k)
        for i in range(k + 1, q):
            partial[k, i] = 2.0 * rng.beta(b, b) - 1.0
            p = partial[k, i]
            for m in range(k - 1, -1, -1):  # partial -> raw correlation
                p = p * np.sqrt((1 - partial[m, i] ** 2) * (1 - partial[m, k] ** 2))
                p += partial[m, i] * partial[m, k]
            C[k, i] = C[i, k] = p
    return C
