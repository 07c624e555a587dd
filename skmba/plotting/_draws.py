"""Posterior draws given as an ArviZ object.

:func:`plot_posterior` and :func:`plot_traces` take, besides a calibrator or
an array, the output of :meth:`~skmba.ModularBayesCalibrator.to_inference_data`
or of any other sampler: an ArviZ ``InferenceData`` (ArviZ 0.x), an
``xarray.DataTree`` (ArviZ 1.x) or the ``posterior`` group itself (an
``xarray.Dataset``). Each variable of the posterior group, of dimensions
``(chain, draw, ...)``, is a parameter; a variable with more dimensions
gives one parameter per element, named ``name[i]``.

Neither ArviZ nor xarray is imported here: an object can only be one of
theirs if its library is already imported.

Examples
--------
>>> import numpy as np
>>> import xarray as xr
>>> from skmba.plotting._draws import arviz_groups, posterior_chains
>>> posterior = xr.Dataset({"E": (("chain", "draw"), np.zeros((2, 5))),
...                         "k": (("chain", "draw", "i"), np.zeros((2, 5, 2)))})
>>> chains, names, sampler = posterior_chains(arviz_groups(posterior))
>>> chains.shape, names
((2, 5, 3), ['E', 'k[0]', 'k[1]'])
"""

import itertools
import sys

import numpy as np


def arviz_groups(obj):
    """``{group: xarray.Dataset}`` of an ArviZ object, or None for others.

    An ``InferenceData`` or a ``DataTree`` gives its groups; a ``Dataset``
    is taken as the posterior group.
    """
    xarray = sys.modules.get("xarray")
    if xarray is None:
        return None
    if isinstance(obj, xarray.Dataset):
        return {"posterior": obj}
    # xarray.DataTree is in xarray >= 2024.10 (ArviZ 1.x builds on it).
    data_tree = getattr(xarray, "DataTree", None)
    if data_tree is not None and isinstance(obj, data_tree):
        return {name: node.to_dataset() for name, node in obj.children.items()}
    arviz = sys.modules.get("arviz")
    # InferenceData is ArviZ 0.x's container; ArviZ 1.x returns DataTrees.
    inference_data = None if arviz is None else getattr(arviz, "InferenceData", None)
    if inference_data is not None and isinstance(obj, inference_data):
        return {name: obj[name] for name in obj.groups()}
    return None


def _parameters(dataset, group):
    """The draws (n_chains, n_draws, r) and names of a group's variables."""
    arrays, names = [], []
    for name, variable in dataset.data_vars.items():
        if "chain" not in variable.dims or "draw" not in variable.dims:
            raise ValueError(
                f"The {group} variable {name!r} has dimensions {variable.dims}; "
                "expected (chain, draw, ...)."
            )
        variable = variable.transpose("chain", "draw", ...)
        values = np.asarray(variable.values, dtype=float)
        extra = variable.dims[2:]
        arrays.append(values.reshape(*values.shape[:2], -1))
        if not extra:
            names.append(str(name))
            continue
        labels = [variable[dim].values for dim in extra]
        names.extend(
            f"{name}[{', '.join(str(v) for v in index)}]"
            for index in itertools.product(*labels)
        )
    if not arrays:
        raise ValueError(f"The {group} group has no variables.")
    return np.concatenate(arrays, axis=2), names


def posterior_chains(groups):
    """The posterior chains (n_chains, n_draws, r), the parameter names and
    the ``sampler`` attribute of the posterior group ("" when absent)."""
    if "posterior" not in groups:
        raise ValueError(
            f"The ArviZ object has no posterior group (groups: {list(groups)})."
        )
    posterior = groups["posterior"]
    chains, names = _parameters(posterior, "posterior")
    return chains, names, str(posterior.attrs.get("sampler", ""))


def prior_draws(groups, names):
    """The prior draws (n, r) of the parameters ``names``, or None when the
    object has no prior group with exactly these parameters."""
    if "prior" not in groups:
        return None
    draws, prior_names = _parameters(groups["prior"], "prior")
    if prior_names != names:
        return None
    return draws.reshape(-1, len(names))


class DrawnPrior:
    """A prior known only by its draws (an ArviZ prior group).

    It has what :func:`plot_posterior` asks of a prior without a density:
    ``dim``, ``bounds`` (central intervals of the draws) and ``rvs`` (the
    draws themselves), so that its marginals are drawn as histograms.

    >>> prior = DrawnPrior(np.arange(101.0)[:, None])
    >>> prior.bounds(0.9).tolist()
    [[5.0, 95.0]]
    """

    def __init__(self, draws):
        self.draws = np.asarray(draws, dtype=float)
        self.dim = self.draws.shape[1]

    def bounds(self, mass):
        tail = (1.0 - mass) / 2.0
        return np.quantile(self.draws, [tail, 1.0 - tail], axis=0).T

    def rvs(self, size=None, random_state=None):
        """All the draws (``size`` and ``random_state`` are ignored)."""
        return self.draws
