"""The seeded problems of the validity suite (issue 13's table): a1 ... freq.

Each case is a function ``case(seed) -> Case`` building one replicate: the
field data ``X, y``, the simulations ``X_sim, theta_sim, y_sim``, the
``prior``, the true parameters ``theta_true``, the noise-free reality
``reality_fn(X) -> (n, q)`` and the noise standard deviation ``noise_sd``
per response. ``Case`` is a named tuple, so it unpacks as the 9-tuple
``(X, y, X_sim, theta_sim, y_sim, prior, theta_true, reality_fn, noise_sd)``.

Noise (all cases): Gaussian, with variance the (population) variance of the
noise-free reality over the field inputs divided by 10^3 (30 dB), per
response. ``CASES`` maps each name to its builder, the range of the design
variables (where the held-out inputs of the predictive checks lie) and a
one-line description.

Callers: :func:`validation.suite.registry` (which renames this module's
``sbc_a1`` and ``sbc_a2``, theta* drawn without a discrepancy, to
``sbc0_a1`` and ``sbc0_a2``), :mod:`validation.sbc_cases` (the shared
designs and helpers), the studies of :mod:`validation.studies` and the
tests in ``tests/validation``. Run ``python -m validation`` for the suite;
the cases are described in ``docs/validity.rst``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import stats

from skmba.datasets import make_cantilever
from skmba.datasets._design import latin_hypercube

SNR_DB = 30.0

# a1/b1/c1/c3: the thesis cantilever (section 4.7.1), E only, tip displacement
# and energy, 70 LHS simulations, 25 observations.
CANTILEVER_SIZES = (70, 25)
CANTILEVER_X_BOUNDS = np.array([[1.0e3, 10.0e3]])  # force F [N], Table 4.1
BUMP_MM = 0.1  # b1: half-sine bump in F on the tip displacement [mm]
SPRING_C1 = 1.5e12  # make_cantilever's default spring (Table 4.1)
SPRING_C3 = 1.5e11  # section 4.7.5, large discrepancy

# a2/b2: two responses quadratic in x, linear in theta.
A2_THETA_TRUE = np.array([2.0, 1.6])
A2_BOUNDS = np.array([[1.0, 3.0], [1.0, 3.0]])
A2_SIZES = (60, 20)
B2_AMPLITUDE = 0.2

# freq: an identifiable design (theta sets a frequency).
FREQ_THETA_TRUE = np.array([3.1])
FREQ_BOUNDS = np.array([[2.0, 4.0]])
FREQ_SIZES = (150, 30)
FREQ_DISCREPANCY = 0.1  # 0.1 x^2

UNIT_X_BOUNDS = np.array([[0.0, 1.0]])


class Case(NamedTuple):
    """One replicate of a case; unpacks as the 9-tuple of the suite."""

    X: np.ndarray
    y: np.ndarray
    X_sim: np.ndarray
    theta_sim: np.ndarray
    y_sim: np.ndarray
    prior: list
    theta_true: np.ndarray
    reality_fn: object
    noise_sd: np.ndarray


class CaseSpec(NamedTuple):
    """A case of the suite: its builder, input range and description."""

    build: object
    X_bounds: np.ndarray
    parameter_names: tuple
    description: str


# --------------------------------------------------------------------------
# shared steps
# --------------------------------------------------------------------------


def _rng(seed, stream):
    """An independent generator per (seed, purpose)."""
    return np.random.default_rng([int(seed), stream])


def _lhs(n, bounds, rng):
    """``n`` Latin-hypercube points over the box ``bounds`` (d, 2)."""
    bounds = np.asarray(bounds, dtype=float)
    unit = latin_hypercube(n, len(bounds), rng)
    return bounds[:, 0] + unit * (bounds[:, 1] - bounds[:, 0])


def noise_sd_at(y_true, snr_db=SNR_DB):
    """Noise standard deviation per response at ``snr_db`` over ``y_true``."""
    return np.sqrt(np.var(y_true, axis=0) / 10.0 ** (snr_db / 10.0))


def _observe(reality_fn, X, seed, snr_db=SNR_DB):
    """Noisy observations of ``reality_fn`` at ``X`` and the noise sd."""
    y_true = reality_fn(X)
    sd = noise_sd_at(y_true, snr_db)
    y = y_true + _rng(seed, 1).normal(size=y_true.shape) * sd
    return y, sd


def _uniform_prior(bounds):
    return [stats.uniform(loc=lo, scale=hi - lo) for lo, hi in bounds]


# --------------------------------------------------------------------------
# the cantilever: a1, b1, c1, c3, sbc_a1
# --------------------------------------------------------------------------


class _PlusBump:
    """``reality(X)`` plus a half-sine bump in F on the tip displacement."""

    def __init__(self, reality, amplitude, bounds):
        self.reality, self.amplitude, self.bounds = reality, amplitude, bounds

    def __call__(self, X):
        X = np.asarray(X, dtype=float)
        lo, hi = self.bounds[0]
        out = np.array(self.reality(X), dtype=float)
        out[:, 0] += self.amplitude * np.sin(np.pi * (X[:, 0] - lo) / (hi - lo))
        return out


def _cantilever(seed, *, spring, E_true=70e3, bump=0.0):
    """The cantilever of section 4.7.1 (E only) with the given spring."""
    n_sim, n_obs = CANTILEVER_SIZES
    data = make_cantilever(
        n_sim,
        n_obs,
        spring_stiffness=spring,
        E_true=E_true,
        snr_db=None,
        random_state=int(seed),
    )
    reality = data.reality
    if bump:
        reality = _PlusBump(reality, bump, CANTILEVER_X_BOUNDS)
    y, sd = _observe(reality, data.X_obs, seed)
    return Case(
        data.X_obs,
        y,
        data.X_sim,
        data.theta_sim,
        data.y_sim,
        data.prior,
        data.theta_true,
        reality,
        sd,
    )


def case_a1(seed):
    """a1: the cantilever, reality = the model (no spring), E* = 70 GPa."""
    return _cantilever(seed, spring=np.inf)


def case_b1(seed):
    """b1: a1 plus a 0.1 mm half-sine bump in F on the tip displacement."""
    return _cantilever(seed, spring=np.inf, bump=BUMP_MM)


def case_c1(seed):
    """c1: the thesis cantilever, spring K* = 1.5e12 N mm/rad."""
    return _cantilever(seed, spring=SPRING_C1)


def case_c3(seed):
    """c3: the cantilever with a soft spring K* = 1.5e11 N mm/rad."""
    return _cantilever(seed, spring=SPRING_C3)


def case_sbc_a1(seed):
    """sbc_a1: a1 with E* drawn from the prior U(20, 100) GPa per seed."""
    lo, hi = 20e3, 100e3
    E_true = lo + (hi - lo) * _rng(seed, 2).uniform()
    return _cantilever(seed, spring=np.inf, E_true=E_true)


# --------------------------------------------------------------------------
# the quadratic pair: a2, b2, sbc_a2
# --------------------------------------------------------------------------


def quadratic_model(X, theta):
    """y1 = t1 x + t2 x^2, y2 = t2 x - 0.5 t1 x^2 (row by row)."""
    x = np.asarray(X, dtype=float)[:, 0]
    theta = np.asarray(theta, dtype=float)
    t1, t2 = theta[:, 0], theta[:, 1]
    return np.column_stack([t1 * x + t2 * x**2, t2 * x - 0.5 * t1 * x**2])


class _QuadraticReality:
    """The quadratic model at ``theta`` plus ``amplitude * sin(2 pi x)`` on y1."""

    def __init__(self, theta, amplitude=0.0):
        self.theta, self.amplitude = np.asarray(theta, dtype=float), amplitude

    def __call__(self, X):
        X = np.asarray(X, dtype=float)
        out = quadratic_model(X, np.tile(self.theta, (len(X), 1)))
        out[:, 0] += self.amplitude * np.sin(2.0 * np.pi * X[:, 0])
        return out


def _quadratic(seed, theta_true, amplitude=0.0):
    n_sim, n_obs = A2_SIZES
    rng = _rng(seed, 0)
    design = _lhs(n_sim, np.vstack([UNIT_X_BOUNDS, A2_BOUNDS]), rng)
    X_sim, theta_sim = design[:, :1], design[:, 1:]
    X = _lhs(n_obs, UNIT_X_BOUNDS, rng)
    reality = _QuadraticReality(theta_true, amplitude)
    y, sd = _observe(reality, X, seed)
    return Case(
        X,
        y,
        X_sim,
        theta_sim,
        quadratic_model(X_sim, theta_sim),
        _uniform_prior(A2_BOUNDS),
        np.asarray(theta_true, dtype=float),
        reality,
        sd,
    )


def case_a2(seed):
    """a2: the quadratic pair, reality = the model at theta* = (2, 1.6)."""
    return _quadratic(seed, A2_THETA_TRUE)


def case_b2(seed):
    """b2: a2 plus 0.2 sin(2 pi x) on y1 only."""
    return _quadratic(seed, A2_THETA_TRUE, B2_AMPLITUDE)


def case_sbc_a2(seed):
    """sbc_a2: a2 with theta* drawn from the prior U(1, 3)^2 per seed."""
    lo, hi = A2_BOUNDS[:, 0], A2_BOUNDS[:, 1]
    theta_true = lo + (hi - lo) * _rng(seed, 2).uniform(size=2)
    return _quadratic(seed, theta_true)


# --------------------------------------------------------------------------
# the identifiable design: freq
# --------------------------------------------------------------------------


def frequency_model(X, theta):
    """y = sin(2 pi theta x) + 0.5 x (row by row), shape (n, 1)."""
    x = np.asarray(X, dtype=float)[:, 0]
    t = np.asarray(theta, dtype=float)[:, 0]
    return (np.sin(2.0 * np.pi * t * x) + 0.5 * x)[:, None]


class _FrequencyReality:
    """``model`` (the frequency model by default) at ``theta`` plus the
    discrepancy ``amplitude x^2``."""

    def __init__(self, theta, amplitude=FREQ_DISCREPANCY, model=None):
        self.theta = np.asarray(theta, dtype=float)
        self.amplitude = float(amplitude)
        self.model = frequency_model if model is None else model

    def __call__(self, X):
        X = np.asarray(X, dtype=float)
        out = self.model(X, np.tile(self.theta, (len(X), 1)))
        return out + self.amplitude * X[:, :1] ** 2


def _frequency_case(seed, model, bounds, theta_true, amplitude, snr_db):
    """freq's design and sizes for ``model`` with parameters in ``bounds``."""
    n_sim, n_obs = FREQ_SIZES
    rng = _rng(seed, 0)
    design = _lhs(n_sim, np.vstack([UNIT_X_BOUNDS, bounds]), rng)
    X_sim, theta_sim = design[:, :1], design[:, 1:]
    X = _lhs(n_obs, UNIT_X_BOUNDS, rng)
    reality = _FrequencyReality(theta_true, amplitude, model)
    y, sd = _observe(reality, X, seed, snr_db)
    return Case(
        X,
        y,
        X_sim,
        theta_sim,
        model(X_sim, theta_sim),
        _uniform_prior(bounds),
        theta_true.copy(),
        reality,
        sd,
    )


def case_freq(seed, *, amplitude=FREQ_DISCREPANCY, snr_db=SNR_DB):
    """freq: y = sin(2 pi theta x) + 0.5 x, theta* = 3.1, discrepancy 0.1 x^2
    (``amplitude`` x^2), noise at ``snr_db``."""
    return _frequency_case(
        seed, frequency_model, FREQ_BOUNDS, FREQ_THETA_TRUE, amplitude, snr_db
    )


#: freq with an offset: theta* = (3.1, 0.2), the offset uniform on
#: [-0.5, 0.5]. A discrepancy with a constant mean (the default regression)
#: absorbs any offset, so the offset is confounded and the frequency is not:
#: a two-parameter design where only one parameter should be flagged.
OFFSET_THETA_TRUE = np.array([3.1, 0.2])
OFFSET_BOUNDS = np.array([[2.0, 4.0], [-0.5, 0.5]])


def offset_model(X, theta):
    """The frequency model plus ``theta[:, 1]`` (row by row), shape (n, 1)."""
    t = np.asarray(theta, dtype=float)
    return frequency_model(X, t[:, :1]) + t[:, 1:2]


def case_freq_offset(seed, *, amplitude=FREQ_DISCREPANCY, snr_db=SNR_DB):
    """freq + offset: y = sin(2 pi t1 x) + 0.5 x + t2, theta* = (3.1, 0.2),
    discrepancy ``amplitude`` x^2, freq's design and sizes."""
    return _frequency_case(
        seed, offset_model, OFFSET_BOUNDS, OFFSET_THETA_TRUE, amplitude, snr_db
    )


CASES = {
    "a1": CaseSpec(
        case_a1,
        CANTILEVER_X_BOUNDS,
        ("E",),
        "cantilever, E only, reality = the model (no spring), tip displacement "
        "+ energy, 70 sims, 25 obs",
    ),
    "a2": CaseSpec(
        case_a2,
        UNIT_X_BOUNDS,
        ("t1", "t2"),
        "y1 = t1 x + t2 x^2, y2 = t2 x - 0.5 t1 x^2, prior U(1,3)^2, "
        "theta* = (2, 1.6), 60 sims, 20 obs",
    ),
    "b1": CaseSpec(
        case_b1,
        CANTILEVER_X_BOUNDS,
        ("E",),
        "a1 + 0.1 mm half-sine bump in F on the tip displacement",
    ),
    "b2": CaseSpec(case_b2, UNIT_X_BOUNDS, ("t1", "t2"), "a2 + 0.2 sin(2 pi x) on y1"),
    "c1": CaseSpec(
        case_c1, CANTILEVER_X_BOUNDS, ("E",), "thesis cantilever, spring K* = 1.5e12"
    ),
    "c3": CaseSpec(
        case_c3, CANTILEVER_X_BOUNDS, ("E",), "cantilever, spring K* = 1.5e11"
    ),
    "freq": CaseSpec(
        case_freq,
        UNIT_X_BOUNDS,
        ("theta",),
        "y = sin(2 pi theta x) + 0.5 x, theta ~ U(2,4), theta* = 3.1, "
        "discrepancy 0.1 x^2, 150 sims, 30 obs",
    ),
    "sbc_a1": CaseSpec(
        case_sbc_a1, CANTILEVER_X_BOUNDS, ("E",), "a1 with E* drawn from the prior"
    ),
    "sbc_a2": CaseSpec(
        case_sbc_a2, UNIT_X_BOUNDS, ("t1", "t2"), "a2 with theta* drawn from the prior"
    ),
}
