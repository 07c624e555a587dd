"""The chains' coordinates of theta: log coordinates for positive
parameters, soft ends for a finite support, with known answers."""

import numpy as np
import pytest
from scipy import integrate, stats

from skmba.calibration._module3_coordinates import EDGE_SHARE, SamplingCoordinates
from skmba.priors._theta import check_prior


def test_finite_supports_have_soft_ends():
    """The sampling coordinates of each kind of support, with known answers:
    away from a finite support's ends the coordinate is the parameter (or
    its log); the ends are pushed to infinity; the prior carried to the
    coordinates is a density (it integrates to one)."""
    dists = [
        stats.uniform(-1.0, 2.0),  # finite support with a negative end
        stats.loguniform(1.0, 10.0),  # finite and positive: of log theta
        stats.lognorm(0.5),  # positive, unbounded above: log
        stats.norm(0.0, 1.0),  # unbounded: linear
    ]
    prior = check_prior(dists)
    theta_sim = prior.rvs(50, random_state=0)
    coords = SamplingCoordinates.of(prior, theta_sim)
    assert list(coords.bounded_dims) == [True, True, False, False]
    assert list(coords.log_dims) == [False, True, True, False]
    # simulations on a support's end (a factorial design's corners) leave
    # out that coordinate only; with none inside, it is left unscaled
    corners = theta_sim.copy()
    corners[:, 0] = np.where(np.arange(50) % 2, -1.0, 1.0)
    on_ends = SamplingCoordinates.of(prior, corners)
    assert (on_ends.u_mean[0], on_ends.u_scale[0]) == (0.0, 1.0)
    np.testing.assert_allclose(on_ends.u_mean[1:], coords.u_mean[1:], rtol=1e-12)
    np.testing.assert_allclose(on_ends.u_scale[1:], coords.u_scale[1:], rtol=1e-12)
    # [0, b]: plain log coordinates, whose lower end is minus infinity
    zero = check_prior([stats.uniform(0.0, 2.0)])
    at_zero = SamplingCoordinates.of(zero, zero.rvs(20, random_state=0))
    assert list(at_zero.log_dims) == [True] and list(at_zero.bounded_dims) == [False]
    theta = prior.rvs(200, random_state=1)
    U = coords.to_u(theta)
    np.testing.assert_allclose(coords.from_u(U), theta, rtol=1e-12)
    v = U * coords.u_scale + coords.u_mean
    x = np.column_stack(
        [theta[:, 0], np.log(theta[:, 1]), np.log(theta[:, 2]), theta[:, 3]]
    )
    # at least ten edge scales from both ends, v = x within 2 s exp(-10)
    width = np.array([2.0, np.log(10.0)])
    low = np.array([-1.0, 0.0])
    distance = np.minimum(x[:, :2] - low, low + width - x[:, :2]) / (EDGE_SHARE * width)
    inner = distance >= 10
    assert inner.mean() > 0.5
    gap = np.abs(v[:, :2] - x[:, :2]) / (EDGE_SHARE * width)
    assert np.all(gap[inner] <= 2 * np.exp(-10))
    np.testing.assert_allclose(v[:, 2:], x[:, 2:], rtol=1e-14, atol=1e-14)
    # the uniform and the log-uniform prior, carried to v: densities
    for j in (0, 1):
        own = check_prior([dists[j]])
        one = SamplingCoordinates.of(own, theta_sim[:, [j]])

        def density(vj, own=own, one=one):
            t = one.from_u(np.array([[(vj - one.u_mean[0]) / one.u_scale[0]]]))
            return float(np.exp(own.logpdf(t)[0] + one.log_jacobian(t)[0]))

        a, b = low[j], low[j] + width[j]
        mass, _ = integrate.quad(
            density, a - width[j], b + width[j], points=[a, b], limit=200
        )
        assert mass == pytest.approx(1.0, abs=1e-6)
    # every u, however far out, is a theta inside the supports; their ends
    # have no finite u
    far = coords.from_u(np.array([[60.0, 60.0, 0.0, 0.0], [-60.0, -60.0, 0.0, 0.0]]))
    assert np.all((far[:, 0] >= -1.0) & (far[:, 0] <= 1.0))
    assert np.all((far[:, 1] >= 1.0) & (far[:, 1] <= 10.0))
    ends = np.array([[-1.0, 1.0, 1.0, 0.0], [1.0, 10.0, 1.0, 0.0]])
    assert not np.any(np.isfinite(coords.to_u(ends)[:, :2]))
    assert np.all(coords.log_jacobian(ends) == -np.inf)
