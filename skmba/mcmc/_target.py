"""The target's log density, evaluated for a chain.

A chain (:class:`skmba.mcmc._chain.Chain`) and the starts checked by
:func:`skmba.mcmc._run.run_chains` call the target through these functions,
which turn what it raises or returns wrongly (NaN, ``+inf``, a wrong shape)
into a ``RuntimeError`` naming the chain:

* :func:`evaluate`: ``log_density(theta)`` at one point;
* :func:`evaluate_batch`: at several points, in one call to the target's
  ``batch`` method when it has one;
* :func:`evaluate_labelled`: the joint log density ``p(theta, k)`` of a
  labelled target (a finite mixture sampled with its component);
* :func:`checked_values`: the check of the vectorised methods' values;
* :func:`evaluate_with_blob`, :func:`evaluate_batch_with_blobs`: the same
  with the target's blobs (extra values it computes with its log density,
  after emcee's), for chains that keep them at their draws.

Examples
--------
>>> import numpy as np
>>> from skmba.mcmc._target import evaluate, evaluate_batch
>>> def log_density(theta):
...     return -0.5 * float(theta @ theta)
>>> evaluate(log_density, np.array([1.0, 1.0]), chain=0)
-1.0
>>> evaluate_batch(log_density, np.ones((2, 2)), chain=0)
array([-1., -1.])
"""

import math

import numpy as np


def evaluate(log_density, theta, chain):
    """``log_density(theta)`` as a float, errors naming the chain."""
    try:
        value = float(log_density(theta))
    except Exception as exc:
        raise RuntimeError(
            f"log_density raised {type(exc).__name__} in chain {chain} at "
            f"theta={theta!r}: {exc}"
        ) from exc
    if value != value or value == math.inf:
        raise RuntimeError(
            f"log_density returned {value} in chain {chain} at theta={theta!r}; "
            "it must return a finite float or -inf (zero density)"
        )
    return value


def checked_values(method, name, n, chain, *args):
    """``method(*args)`` as ``n`` log densities, errors naming ``name`` and
    the chain."""
    try:
        values = np.asarray(method(*args), dtype=float)
    except Exception as exc:
        raise RuntimeError(
            f"log_density.{name} raised {type(exc).__name__} in chain {chain} at "
            f"{n} points: {exc}"
        ) from exc
    if values.shape != (n,) or np.any(np.isnan(values) | (values == np.inf)):
        raise RuntimeError(
            f"log_density.{name} returned {values!r} in chain {chain}; it must "
            f"return {n} finite floats or -inf (zero density)"
        )
    return values


def evaluate_batch(log_density, thetas, chain):
    """``log_density`` at each row of ``thetas``, in one call to its
    ``batch`` method when it has one."""
    batch = getattr(log_density, "batch", None)
    if batch is None:
        return np.array([evaluate(log_density, t.copy(), chain) for t in thetas])
    return checked_values(batch, "batch", len(thetas), chain, thetas)


def evaluate_labelled(log_density, thetas, labels, chain):
    """The joint log density of a labelled target at ``(thetas[b], labels[b])``."""
    return checked_values(
        log_density.labelled, "labelled", len(thetas), chain, thetas, labels
    )


def evaluate_with_blob(log_density, theta, chain):
    """``log_density.with_blob(theta)``: the value (checked as by
    :func:`evaluate`) and the blob, an ndarray."""
    blobs = []

    def value(point):
        result, blob = log_density.with_blob(point)
        blobs.append(np.asarray(blob, dtype=float))
        return result

    return evaluate(value, theta, chain), blobs[0]


def evaluate_batch_with_blobs(log_density, thetas, chain):
    """``log_density.batch_with_blobs(thetas)``: the values at the rows of
    ``thetas`` (checked as by :func:`evaluate_batch`) and their blobs, an
    ndarray with one row per theta."""
    blobs = []

    def values(points):
        result, blob = log_density.batch_with_blobs(points)
        blobs.append(np.asarray(blob, dtype=float))
        return result

    out = checked_values(values, "batch_with_blobs", len(thetas), chain, thetas)
    if len(blobs[0]) != len(thetas):
        raise RuntimeError(
            f"log_density.batch_with_blobs returned {len(blobs[0])} blobs for "
            f"{len(thetas)} points in chain {chain}; it must return one per point"
        )
    return out, blobs[0]
