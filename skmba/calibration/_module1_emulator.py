"""Module 1 of the modular Bayesian approach: the emulator of the model.

The simulations ``y_sim = f(X_sim, theta_sim)`` are standardised (thesis
appendix C.2: each input, parameter and response centred and scaled by its
spread over the simulations) and emulated by a noise-free
:class:`~skmba.MultiResponseGP` on the inputs ``z = [x, theta]``.

* :class:`Standardizer` holds the centring and scaling, the one home of the
  conversion between user and standardised units.
* :func:`fit_emulator` fits module 1 and returns a frozen :class:`Emulator`.
* :meth:`Emulator.conditional` is the one home of the emulator conditioned
  on the simulations at the field inputs ``[X_e, theta]`` for one or many
  ``theta``: module 2 integrates it over the prior, module 3 builds the
  global model from it and the sensor designer evaluates it for all
  response subsets at once.

Examples
--------
>>> import numpy as np
>>> from skmba.calibration._module1_emulator import Standardizer, fit_emulator
>>> rng = np.random.default_rng(0)
>>> X, theta = rng.uniform(size=(30, 1)), rng.uniform(1, 2, size=(30, 1))
>>> y = np.hstack([X * theta, X + theta])
>>> scaler = Standardizer.from_simulations(X, theta, y)
>>> emulator = fit_emulator(scaler, X, theta, y, random_state=0)
>>> cond = emulator.conditional(scaler.x(X[:3]), scaler.theta(np.array([[1.5]])))
>>> cond.mean().shape, cond.correlation().shape
((1, 3, 2), (1, 3, 3))
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import linalg

from skmba._core.dace import DACECorrelation
from skmba._core.progress import as_progress, start_reporter
from skmba._core.regression import regression_basis
from skmba.gp._estimator import MultiResponseGP, default_kernel

#: Nugget on the response covariance of the emulator: under a tip load a
#: beam's displacements and rotation are exactly proportional in the model.
RESPONSE_NUGGET = 1e-8


def _centre_scale(A):
    scale = A.std(axis=0)
    return A.mean(axis=0), np.where(scale > 0, scale, 1.0)


@dataclass(frozen=True)
class Standardizer:
    """Centring and scaling of inputs, parameters and responses.

    The simulations are the reference (appendix C.2); a column without
    spread keeps the scale 1.

    Attributes
    ----------
    X_mean, X_scale : ndarray of shape (d,)
    theta_offset, theta_scale : ndarray of shape (r,)
    y_mean, y_scale : ndarray of shape (q,)

    Examples
    --------
    >>> import numpy as np
    >>> s = Standardizer.from_simulations(
    ...     np.array([[0.0], [2.0]]), np.array([[1.0], [3.0]]), np.array([[5.0], [7.0]])
    ... )
    >>> s.x(np.array([[2.0]])), s.y_to_user(np.array([[0.0]]))
    (array([[1.]]), array([[6.]]))
    """

    X_mean: np.ndarray
    X_scale: np.ndarray
    theta_offset: np.ndarray
    theta_scale: np.ndarray
    y_mean: np.ndarray
    y_scale: np.ndarray

    @classmethod
    def from_simulations(cls, X_sim, theta_sim, y_sim):
        """The standardisation with the simulations as reference."""
        return cls(
            *_centre_scale(X_sim), *_centre_scale(theta_sim), *_centre_scale(y_sim)
        )

    def x(self, X):
        """Design variables in standardised units."""
        return (X - self.X_mean) / self.X_scale

    def theta(self, theta):
        """Calibration parameters in standardised units."""
        return (theta - self.theta_offset) / self.theta_scale

    def y(self, Y):
        """Responses in standardised units."""
        return (Y - self.y_mean) / self.y_scale

    def y_to_user(self, Ys, *, centred=True):
        """Standardised responses back in user units (``centred=False``: a
        difference such as the discrepancy, without the offset)."""
        offset = self.y_mean if centred else 0.0
        return Ys * self.y_scale + offset

    def y_covariance_to_user(self, S):
        """A (q, q) covariance of standardised responses in user units."""
        return S * np.outer(self.y_scale, self.y_scale)


@dataclass(frozen=True)
class Emulator:
    """The fitted module-1 emulator, in standardised units (frozen).

    Attributes
    ----------
    gp : MultiResponseGP
        The fitted noise-free GP on ``Z`` (its ``likelihood_`` holds the
        factorisation).
    Z : ndarray of shape (N, d + r)
        Standardised simulation inputs ``[X_sim, theta_sim]``.
    Y : ndarray of shape (N, q)
        Standardised simulated responses.
    regression : str
        The regression basis of the emulator.

    Examples
    --------
    See the module docstring.
    """

    gp: MultiResponseGP
    Z: np.ndarray
    Y: np.ndarray
    regression: str

    @property
    def likelihood(self):
        """The factorised likelihood state (``C``, ``gls``, ``sigma2``)."""
        return self.gp.likelihood_

    @property
    def kernel(self):
        return self.gp.kernel_

    @property
    def nugget(self):
        """The emulator's nugget on the diagonal of its correlation."""
        return self.gp.nugget_

    @property
    def C(self):
        """Cholesky factor of the simulations' correlation (N, N)."""
        return self.likelihood.C

    @property
    def sigma2(self):
        """Response covariance ``Sigma2_m`` (q, q)."""
        return self.likelihood.sigma2

    @property
    def H_white(self):
        """``C^-1 H_m`` (N, p_m)."""
        return self.likelihood.gls.H_white

    @cached_property
    def Y_white(self):
        """``C^-1 Y_m`` (N, q)."""
        return linalg.solve_triangular(self.C, self.Y, lower=True)

    @property
    def N(self):
        return len(self.Z)

    @property
    def q(self):
        return self.Y.shape[1]

    def field_correlation(self, X_e):
        """``R_m`` at ``[X_e, theta]`` (n, n) when it is the same for every
        theta, else None.

        With a stationary kernel the correlation depends on differences
        only, and all field points share theta: the theta differences are
        exactly zero, so this equals, bit for bit, the correlation at any
        theta.
        """
        if not self.kernel.is_stationary():
            return None
        r = self.Z.shape[1] - X_e.shape[1]
        return self.kernel(np.hstack([X_e, np.zeros((len(X_e), r))]))

    @cached_property
    def _weights(self):
        """``C^-T C^-1 (Y_m - H_m beta)`` (N, q): the kriging mean's weights."""
        residual = self.likelihood.gls.residual
        return linalg.solve_triangular(self.C, residual, lower=True, trans="T")

    def kriging_mean(self, X_e, thetas):
        """The kriging mean at ``[X_e, theta]`` per theta (k, n, q), as
        :meth:`EmulatorConditional.mean` without its triangular solve.

        A DACE correlation is a product over the inputs, so its cross
        correlation is that of the design variables (n, N) times that of
        the parameters (k, N), each evaluated with the other columns equal
        (their factors one): k + n rows instead of k n.
        """
        thetas = np.atleast_2d(thetas)
        k, n = len(thetas), len(X_e)
        points = np.hstack([np.tile(X_e, (k, 1)), np.repeat(thetas, n, axis=0)])
        trend = regression_basis(points, self.regression) @ self.likelihood.gls.beta
        trend = trend.reshape(k, n, -1)
        if not isinstance(self.kernel, DACECorrelation):
            cross = self.kernel(points, self.Z) @ self._weights
            return trend + cross.reshape(k, n, -1)
        d = X_e.shape[1]
        on_x, on_theta = self.Z.copy(), self.Z.copy()
        on_x[:, d:], on_theta[:, :d] = 0.0, 0.0
        K_x = self.kernel(np.hstack([X_e, np.zeros((n, self.Z.shape[1] - d))]), on_x)
        K_t = self.kernel(np.hstack([np.zeros((k, d)), thetas]), on_theta)
        cross = np.stack(
            [(K_t * w) @ K_x.T for w in self._weights.T], axis=-1
        )  # (k, n, q)
        return trend + cross

    def conditional(self, X_e, thetas):
        """The emulator given the simulations at ``[X_e, theta]`` per theta.

        Parameters
        ----------
        X_e : ndarray of shape (n, d)
            Standardised field inputs.
        thetas : ndarray of shape (k, r)
            Standardised parameter values.

        Returns
        -------
        EmulatorConditional
        """
        thetas = np.atleast_2d(thetas)
        k, n = len(thetas), len(X_e)
        points = np.hstack([np.tile(X_e, (k, 1)), np.repeat(thetas, n, axis=0)])
        Rt = linalg.solve_triangular(self.C, self.kernel(self.Z, points), lower=True)
        return EmulatorConditional(self, points, Rt, k, n)


@dataclass(frozen=True)
class EmulatorConditional:
    """Pieces of the emulator conditioned on the simulations, at ``k`` theta.

    ``Rt = C^-1 R_m(D_m, D_e(theta))`` with ``D_e(theta) = [X_e, theta]``;
    the others follow on demand:

    * :meth:`mean`: the kriging mean ``h' beta + Rt' C^-1 (Y_m - H_m beta)``;
    * :meth:`correlation`: ``T = R_m(D_e) - Rt' Rt``, the correlation of the
      simulator's output given the simulations with ``beta`` known (the
      nugget is on the simulations only, see :meth:`correlation`);
    * :meth:`universal_correlation`: ``T`` plus the regression term of
      universal kriging (``beta`` estimated);
    * :meth:`H_me`: ``H_m(D_e) - Rt' C^-1 H_m`` and :meth:`M`:
      ``Rt' C^-1 Y_m``, the field rows of the global model's regression and
      data after the simulation block is eliminated (module 3).
    """

    emulator: Emulator
    points: np.ndarray  # (k n, d + r), theta-major
    Rt: np.ndarray  # (N, k n)
    k: int
    n: int

    @cached_property
    def h(self):
        """Regression basis at the points (k n, p_m)."""
        return regression_basis(self.points, self.emulator.regression)

    def _blocks(self, A):
        """(N, k n) -> (N, k, n)."""
        return A.reshape(-1, self.k, self.n)

    def prior_correlation(self):
        """``R_m`` at the points of each theta (k, n, n)."""
        kernel, n = self.emulator.kernel, self.n
        return np.stack(
            [kernel(self.points[i * n : (i + 1) * n]) for i in range(self.k)]
        )

    def mean(self):
        """Kriging mean at the points (k, n, q)."""
        gls = self.emulator.likelihood.gls
        return (self.h @ gls.beta + self.Rt.T @ gls.residual).reshape(
            self.k, self.n, -1
        )

    def correlation(self, prior=None):
        """``R_m(D_e) - Rt' Rt`` per theta (k, n, n).

        The correlation of the simulator's output at the points given the
        simulations, with no nugget of its own: the nugget is in ``C`` (the
        simulations), where it stands for the emulator's smoothing of them;
        a deterministic simulator has no error at a point it was not run at
        beyond what the emulator does not know, which this is. (A nugget
        here, ``alpha`` times the emulator's variance, grows with that
        variance: on a nearly flat emulator it exceeded the noise of the
        readings and did not shrink with their number, docs/internals.rst.)

        ``prior``, of shape (n, n), is ``R_m(D_e)`` when it is known not to
        depend on theta (:meth:`Emulator.field_correlation`).
        """
        n = self.n
        RtRt = [
            self.Rt[:, i * n : (i + 1) * n].T @ self.Rt[:, i * n : (i + 1) * n]
            for i in range(self.k)
        ]
        if prior is None:
            prior = self.prior_correlation()
        return prior - np.stack(RtRt)

    def universal_correlation(self):
        """Correlation of universal kriging per theta (k, n, n)."""
        gls = self.emulator.likelihood.gls
        u = self.h.T - gls.H_white.T @ self.Rt
        ut = self._blocks(linalg.solve_triangular(gls.G, u, trans="T"))
        Rt = self._blocks(self.Rt)
        return (
            self.prior_correlation()
            - np.einsum("mki,mkj->kij", Rt, Rt)
            + np.einsum("mki,mkj->kij", ut, ut)
        )

    def H_me(self):
        """Field rows of the regression, simulations eliminated (k, n, p_m)."""
        H = self.h - self.Rt.T @ self.emulator.H_white
        return H.reshape(self.k, self.n, -1)

    def M(self):
        """``Rt' C^-1 Y_m`` per theta (k, n, q)."""
        return (self.Rt.T @ self.emulator.Y_white).reshape(self.k, self.n, -1)


def fit_emulator(
    scaler,
    X_sim,
    theta_sim,
    y_sim,
    *,
    kernel=None,
    regression="constant",
    alpha=1e-8,
    n_restarts_optimizer=2,
    random_state=None,
    progress=None,
):
    """Module 1: fit the emulator to the standardised simulations.

    Parameters
    ----------
    scaler : Standardizer
    X_sim : ndarray of shape (N, d)
    theta_sim : ndarray of shape (N, r)
    y_sim : ndarray of shape (N, q)
    kernel : sklearn Kernel, default=None
        Correlation on the standardised ``[x, theta]``; None: anisotropic
        :class:`~skmba.kernels.Gauss` scaled to the data.
    regression : {"constant", "linear", "quadratic"}
    alpha : float
        The GP's nugget (escalated by the GP if the factorisation fails).
    n_restarts_optimizer : int
    random_state : int or None
    progress : skmba._core.progress.Progress, default=None
        A bar of the starts of the likelihood search (the first and the
        ``n_restarts_optimizer`` restarts) and, as detail lines, the
        log-likelihood each reaches; None is silent.

    Returns
    -------
    Emulator

    Raises
    ------
    ValueError
        A simulated response is constant over the simulations.
    """
    Z = np.hstack([scaler.x(X_sim), scaler.theta(theta_sim)])
    Ys = scaler.y(y_sim)
    gp = MultiResponseGP(
        default_kernel(Z) if kernel is None else kernel,
        regression=regression,
        alpha=alpha,
        n_restarts_optimizer=n_restarts_optimizer,
        normalize_y=False,
        random_state=random_state,
        response_nugget=RESPONSE_NUGGET,
    )
    progress = as_progress(progress)
    with progress.bar(
        n_restarts_optimizer + 1, f"emulator of {len(Z)} simulations", unit="start"
    ) as bar:
        gp._fit_reporting(Z, Ys, start_reporter(progress, bar, "emulator"))
        if bar.n < bar.total:  # e.g. no hyperparameter to search
            bar.total = bar.n
            bar.refresh()
    if gp.likelihood_ is None or not np.all(gp.active_responses_):
        raise ValueError(
            "A simulated response is constant over the simulations: it "
            "carries no information on theta. Remove it from y and y_sim."
        )
    return Emulator(gp, Z, Ys, regression)
