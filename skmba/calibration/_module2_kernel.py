"""Module 2's discrepancy correlation and the range of its roughness.

:func:`discrepancy_kernel` is the correlation the user gave, or the
default; :func:`bounded_kernel` gives it the prior's roughness range, stated
in the field data's terms (:class:`~skmba.priors._hyperprior.PriorUnits`)
and carried to module 2's standardised inputs with the kernel's
``roughness_power``: the one place where a roughness range changes units,
for the propagated module 2 and the plug-in alike.

Examples
--------
>>> import numpy as np
>>> from skmba.kernels import Gauss
>>> from skmba.priors._hyperprior import PriorUnits
>>> units = PriorUnits(input_ratio=(2.0,), response_ratio=(1.0,))
>>> bounded_kernel(Gauss(1.0), np.zeros((3, 1)), (0.1, 9.0), units).roughness_bounds
(0.4, 36.0)
"""

import numpy as np
from sklearn.base import clone

from skmba.gp._estimator import default_kernel


def discrepancy_kernel(kernel, X):
    """The discrepancy correlation: a clone of ``kernel``, or the default.

    None gives the anisotropic :class:`~skmba.kernels.Gauss` scaled to the
    standardised field inputs ``X`` (:func:`~skmba.gp._estimator.default_kernel`).

    Examples
    --------
    >>> from skmba.kernels import Exp
    >>> discrepancy_kernel(Exp(2.0), np.zeros((3, 1))).roughness
    2.0
    """
    return default_kernel(X) if kernel is None else clone(kernel)


def bounded_kernel(kernel, X_e, roughness, units=None, name="discrepancy_prior"):
    """:func:`discrepancy_kernel` with its roughness bounded by a prior range.

    ``roughness`` is ``(low, high)`` (numbers or (d,) arrays) in the terms of
    ``units`` (None: module 2's own), or None to keep the kernel's bounds;
    a kernel without a ``roughness`` (scikit-learn's) keeps its own only
    when no range is given.
    """
    kernel_d = discrepancy_kernel(kernel, X_e)
    if roughness is None:
        return kernel_d
    d = X_e.shape[1]
    low, high = (np.broadcast_to(np.asarray(b, dtype=float), (d,)) for b in roughness)
    if units is not None:
        power = getattr(kernel_d, "roughness_power", 2.0)
        low, high = units.roughness(low, power), units.roughness(high, power)
    return bound_roughness(kernel_d, low, high, name)


def bound_roughness(kernel, low, high, name="discrepancy_prior"):
    """A clone of ``kernel`` whose roughness is optimised in ``[low, high]``.

    A kernel whose roughness is ``"fixed"`` is returned unchanged.

    Examples
    --------
    >>> from skmba.kernels import Gauss
    >>> bound_roughness(Gauss(0.01), np.array([0.1]), np.array([9.0]))
    Gauss(roughness=0.1)
    """
    params = kernel.get_params()
    if "roughness" not in params:
        raise TypeError(
            f"{name}['roughness'] needs a discrepancy kernel with a 'roughness' "
            f"hyperparameter (the kernels of skmba.kernels), got {kernel!r}; pass "
            f"{name}={{'roughness': None}} to keep the kernel's own bounds."
        )
    if isinstance(params.get("roughness_bounds"), str):  # "fixed"
        return kernel
    roughness = np.asarray(params["roughness"], dtype=float)
    if roughness.ndim == 0:
        if np.ptp(low) > 0 or np.ptp(high) > 0:
            raise ValueError(
                f"{name}['roughness'] gives one range per design variable but "
                f"the kernel {kernel!r} is isotropic; give it one roughness per "
                "design variable or use one range."
            )
        bounds = (float(low[0]), float(high[0]))
        start = float(np.clip(roughness, *bounds))
    else:
        if roughness.size != low.size:
            raise ValueError(
                f"The discrepancy kernel {kernel!r} has {roughness.size} "
                f"roughnesses for {low.size} design variables."
            )
        bounds = np.column_stack([low, high])
        start = np.clip(roughness, low, high)
    return clone(kernel).set_params(roughness=start, roughness_bounds=bounds)
