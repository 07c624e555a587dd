"""The cases of issue 31, item 5: a continuum of discrepancies and larger designs.

Two families, each a builder ``case(seed) -> Case`` (the 9-tuple of
:mod:`validation.cases`):

- :func:`case_continuum`, the continuum from a1 to c3 on the cantilever's
  a1 design (its field inputs, simulations and prior, reused from
  :func:`validation.cases.case_a1`). Reality is the model at E* = 70 GPa
  plus, per response j,
  ``delta_j(F) = size * c3_j * rms_j * (cos(alpha) s_in_j(F) + sin(alpha)
  s_out_j(F))``: ``s_in_j`` the model's sensitivity to a softening
  (``-dy_j/dE`` at E*, central difference), ``s_out_j`` a half-sine bump in
  F with its projection on ``s_in_j`` removed, both of unit rms over the
  field inputs (so orthogonal over them); ``rms_j`` the rms of the model's
  response at E* over the field inputs and ``c3_j`` c3's rms discrepancy
  relative to it (:func:`c3_relative_size`, 3 E* I / (K* L) = 0.315 for
  both responses). ``size`` is therefore a fraction of c3's discrepancy:
  size 0 is a1, and size 1 at alpha = 0 is c3's reality (tested).
  :class:`ContinuumReality` is the picklable reality.
- ``DESIGN_CASES``: designs beyond one input, two responses and two
  parameters, each with the parameters the identifiability warning should
  name: ``two_inputs`` (a frequency amplitude-modulated by a second input,
  identifiable), ``four_responses`` (a1 with four of the cantilever's
  responses: E confounded, as on a1) and ``three_parameters`` (freq +
  offset with an amplitude: the offset confounded, frequency and amplitude
  not).

Noise as in :mod:`validation.cases` (``snr_db`` of the noise-free reality's
variance per response, the same random stream, so size 0 reproduces a1's
observations). Used by :mod:`validation.studies.discrepancy_continuum`;
described in ``docs/validity.rst`` ("A continuum of discrepancies").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import stats
from scipy.stats import qmc

from skmba.datasets import CantileverModel, CantileverReality, make_cantilever
from validation.cases import (
    CANTILEVER_X_BOUNDS,
    FREQ_SIZES,
    SNR_DB,
    SPRING_C3,
    UNIT_X_BOUNDS,
    Case,
    case_a1,
    noise_sd_at,
)

E_STAR = 70.0e3  # the cantilever's E* [MPa]
RELATIVE_STEP = 1e-4  # the central difference's step, relative to E*

# --------------------------------------------------------------------------
# shared steps
# --------------------------------------------------------------------------


def noisy(reality, X, seed, snr_db=SNR_DB):
    """Observations of ``reality`` at ``X`` and the noise sd per response:
    the suite's noise, on its stream ``[seed, 1]``."""
    y_true = reality(X)
    sd = noise_sd_at(y_true, snr_db)
    y = y_true + np.random.default_rng([int(seed), 1]).normal(size=y_true.shape) * sd
    return y, sd


def latin(n, bounds, rng):
    """``n`` Latin-hypercube points over the box ``bounds`` (d, 2)."""
    bounds = np.asarray(bounds, dtype=float)
    unit = qmc.LatinHypercube(d=len(bounds), seed=rng).random(n)
    return bounds[:, 0] + unit * (bounds[:, 1] - bounds[:, 0])


def uniform_prior(bounds):
    """One frozen ``scipy.stats.uniform`` per row of ``bounds``."""
    return [stats.uniform(loc=lo, scale=hi - lo) for lo, hi in bounds]


# --------------------------------------------------------------------------
# the continuum from a1 to c3
# --------------------------------------------------------------------------


def c3_relative_size(X):
    """c3's rms discrepancy over the model's rms response at E*, per
    response, over the inputs ``X``."""
    model = CantileverModel()(X, [E_STAR])
    gap = CantileverReality(E=E_STAR, spring_stiffness=SPRING_C3)(X) - model
    return np.sqrt(np.mean(gap**2, axis=0) / np.mean(model**2, axis=0))


def _softening(X):
    """``-dy/dE`` of the cantilever at E* by central difference (n, q)."""
    model, h = CantileverModel(), RELATIVE_STEP * E_STAR
    return -(model(X, [E_STAR + h]) - model(X, [E_STAR - h])) / (2.0 * h)


def _bump(X):
    """The half-sine bump in F over the cantilever's range, (n, 1)."""
    lo, hi = CANTILEVER_X_BOUNDS[0]
    return np.sin(np.pi * (np.asarray(X, dtype=float)[:, :1] - lo) / (hi - lo))


class ContinuumReality:
    """The model at E* plus ``size`` x c3's discrepancy size in the direction
    ``alpha`` between ``s_in`` (alpha = 0) and ``s_out`` (90 degrees).

    The shapes' constants (norms, projection) are set from the field inputs
    ``X_field``; the reality can then be evaluated anywhere.
    """

    def __init__(self, X_field, size, alpha_deg):
        X_field = np.asarray(X_field, dtype=float)
        self.size, self.alpha_deg = float(size), float(alpha_deg)
        s_in = _softening(X_field)
        self.in_norm = np.sqrt(np.mean(s_in**2, axis=0))
        s_in = s_in / self.in_norm
        bump = _bump(X_field)
        self.projection = np.mean(bump * s_in, axis=0)
        self.out_norm = np.sqrt(np.mean((bump - self.projection * s_in) ** 2, axis=0))
        model = CantileverModel()(X_field, [E_STAR])
        self.amplitude = (
            self.size * c3_relative_size(X_field) * np.sqrt(np.mean(model**2, axis=0))
        )

    def shapes(self, X):
        """``(s_in, s_out)`` at ``X``, each (n, q)."""
        s_in = _softening(X) / self.in_norm
        return s_in, (_bump(X) - self.projection * s_in) / self.out_norm

    def discrepancy(self, X):
        """``delta(X)``, (n, q)."""
        s_in, s_out = self.shapes(X)
        alpha = np.deg2rad(self.alpha_deg)
        return self.amplitude * (np.cos(alpha) * s_in + np.sin(alpha) * s_out)

    def __call__(self, X):
        return CantileverModel()(X, [E_STAR]) + self.discrepancy(X)


def case_continuum(seed, *, size, alpha_deg, snr_db=SNR_DB):
    """a1's design, prior and simulations; reality :class:`ContinuumReality`
    (``size`` in units of c3's discrepancy), noise at ``snr_db``."""
    a1 = case_a1(seed)
    reality = ContinuumReality(a1.X, size, alpha_deg)
    y, sd = noisy(reality, a1.X, seed, snr_db)
    return a1._replace(y=y, reality_fn=reality, noise_sd=sd)


# --------------------------------------------------------------------------
# larger designs: two inputs, four responses, three parameters
# --------------------------------------------------------------------------

TWO_INPUT_BOUNDS = np.array([[0.0, 1.0], [0.0, 1.0]])
TWO_INPUT_SIZES = (200, 40)
FREQ_BOUNDS = np.array([[2.0, 4.0]])
THREE_THETA_TRUE = np.array([3.1, 0.2, 1.0])
THREE_BOUNDS = np.array([[2.0, 4.0], [-0.5, 0.5], [0.5, 1.5]])
THREE_SIZES = (200, FREQ_SIZES[1])
FOUR_RESPONSES = ("tip_displacement", "energy", "tip_rotation", "mid_displacement")
DISCREPANCY = 0.1


def two_input_model(X, theta):
    """y = (1 + 0.5 x2) sin(2 pi theta x1) + 0.5 x1 (row by row), (n, 1)."""
    X = np.asarray(X, dtype=float)
    t = np.asarray(theta, dtype=float)[:, 0]
    wave = (1.0 + 0.5 * X[:, 1]) * np.sin(2.0 * np.pi * t * X[:, 0])
    return (wave + 0.5 * X[:, 0])[:, None]


def three_parameter_model(X, theta):
    """y = t3 sin(2 pi t1 x) + 0.5 x + t2 (row by row), (n, 1)."""
    x = np.asarray(X, dtype=float)[:, 0]
    t = np.asarray(theta, dtype=float)
    wave = t[:, 2] * np.sin(2.0 * np.pi * t[:, 0] * x)
    return (wave + 0.5 * x + t[:, 1])[:, None]


class ModelPlus:
    """``model`` at ``theta`` plus ``amplitude`` x the product of the inputs
    (x1 x2 with two inputs; x^2 with one)."""

    def __init__(self, model, theta, amplitude=DISCREPANCY):
        self.model, self.theta = model, np.asarray(theta, dtype=float)
        self.amplitude = float(amplitude)

    def __call__(self, X):
        X = np.asarray(X, dtype=float)
        out = self.model(X, np.tile(self.theta, (len(X), 1)))
        product = X[:, 0] * (X[:, 1] if X.shape[1] > 1 else X[:, 0])
        return out + self.amplitude * product[:, None]


def _analytic(seed, model, x_bounds, theta_bounds, theta_true, sizes, snr_db):
    """An LHS over inputs x parameters, an LHS of field inputs, reality
    :class:`ModelPlus` and the noise."""
    n_sim, n_obs = sizes
    rng = np.random.default_rng([int(seed), 0])
    d = len(x_bounds)
    design = latin(n_sim, np.vstack([x_bounds, theta_bounds]), rng)
    X_sim, theta_sim = design[:, :d], design[:, d:]
    X = latin(n_obs, x_bounds, rng)
    reality = ModelPlus(model, theta_true)
    y, sd = noisy(reality, X, seed, snr_db)
    return Case(
        X, y, X_sim, theta_sim, model(X_sim, theta_sim), uniform_prior(theta_bounds),
        np.array(theta_true, dtype=float), reality, sd,
    )  # fmt: skip


def case_two_inputs(seed, *, snr_db=SNR_DB):
    """Two inputs: :func:`two_input_model`, theta* = 3.1 in U(2, 4),
    discrepancy 0.1 x1 x2, 200 simulations, 40 observations."""
    return _analytic(
        seed, two_input_model, TWO_INPUT_BOUNDS, FREQ_BOUNDS, [3.1],
        TWO_INPUT_SIZES, snr_db,
    )  # fmt: skip


def case_three_parameters(seed, *, snr_db=SNR_DB):
    """Three parameters: :func:`three_parameter_model`, theta* = (3.1, 0.2,
    1.0), discrepancy 0.1 x^2, 200 simulations, freq's 30 observations."""
    return _analytic(
        seed, three_parameter_model, UNIT_X_BOUNDS, THREE_BOUNDS, THREE_THETA_TRUE,
        THREE_SIZES, snr_db,
    )  # fmt: skip


def case_four_responses(seed, *, snr_db=SNR_DB):
    """a1 with four responses (tip displacement, energy, tip rotation,
    mid-span displacement): E only, no discrepancy, 70 sims, 25 obs."""
    data = make_cantilever(
        70, 25, responses=FOUR_RESPONSES, spring_stiffness=np.inf,
        E_true=E_STAR, random_state=int(seed),
    )  # fmt: skip
    y, sd = noisy(data.reality, data.X_obs, seed, snr_db)
    return Case(
        data.X_obs, y, data.X_sim, data.theta_sim, data.y_sim, data.prior,
        data.theta_true, data.reality, sd,
    )  # fmt: skip


class DesignCase(NamedTuple):
    """A larger design: builder, parameter names, the indices the warning
    should name, and a description."""

    build: object
    parameter_names: tuple
    confounded: tuple
    description: str


DESIGN_CASES = {
    "two_inputs": DesignCase(
        case_two_inputs,
        ("theta",),
        (),
        "y = (1 + 0.5 x2) sin(2 pi theta x1) + 0.5 x1, theta* = 3.1, "
        "discrepancy 0.1 x1 x2, 200 sims, 40 obs",
    ),
    "four_responses": DesignCase(
        case_four_responses,
        ("E",),
        (0,),
        "a1 with tip displacement, energy, tip rotation and mid-span "
        "displacement, 70 sims, 25 obs",
    ),
    "three_parameters": DesignCase(
        case_three_parameters,
        ("frequency", "offset", "amplitude"),
        (1,),
        "y = t3 sin(2 pi t1 x) + 0.5 x + t2, theta* = (3.1, 0.2, 1.0), "
        "discrepancy 0.1 x^2, 200 sims, 30 obs",
    ),
}
