"""Linear-elastic 2-D pin-jointed truss solved by the direct stiffness method.

:class:`Truss` assembles the global stiffness of bars, supports and springs
to the ground, turns temperature changes into equivalent nodal forces,
solves for the nodal displacements (one Cholesky factorisation of the
reduced stiffness) and recovers elongations, strains, bar forces, spring
forces and reactions. It knows nothing of the bridge: the geometry, the
gauges and the temperature fields are in
:mod:`skmba.datasets._truss_bridge_model`.

Forces are in N, lengths in mm, E in MPa (N/mm^2), stiffnesses in N/mm and
temperatures in degC. Global dof ``2 i`` is the ``x`` dof of node ``i`` and
``2 i + 1`` its ``y`` dof. Bar forces and strains are positive in tension;
the mechanical strain of a bar is ``elongation / L - alpha dT``.

Examples
--------
Two bars meet at node 2 above the supports 0 and 1 (a three-hinged frame);
a vertical load of 1 kN at the top puts both in equal compression.

>>> from skmba.datasets._truss_solver import Truss
>>> frame = Truss([[0, 0], [600, 0], [300, 400]], [[0, 2], [1, 2]],
...               E=70e3, A=100, supports=[0, 1, 2, 3])
>>> u = frame.solve(loads=[0, 0, 0, 0, 0, -1000.0])
>>> [round(float(n), 1) for n in frame.bar_forces(u)]
[-625.0, -625.0]
"""

import copy

import numpy as np
from scipy import linalg

__all__ = ["Truss"]

_MECHANISM_RTOL = 1e-10

_MECHANISM_MESSAGE = (
    "The truss is a mechanism: its stiffness matrix, with supports and springs "
    "applied, is singular. Add supports, springs or bars so that every free "
    "degree of freedom is restrained."
)


class Truss:
    """Linear-elastic 2-D pin-jointed truss (direct stiffness method).

    Parameters
    ----------
    nodes : array-like of shape (n_nodes, 2)
        Node coordinates (mm).
    bars : array-like of shape (n_bars, 2)
        Start and end node of each bar. The bar axis points from start to end.
    E, A : float or array-like of shape (n_bars,)
        Young's modulus (MPa) and cross-section area (mm^2), positive.
    alpha : float or array-like of shape (n_bars,), default=0.0
        Coefficient of thermal expansion (1/degC).
    supports : sequence of int, default=()
        Restrained global dofs (``2 * node`` for x, ``2 * node + 1`` for y).
        Their displacement is zero.
    springs : dict or None, default=None
        Map ``{dof: stiffness}`` of linear springs to the ground (N/mm, >= 0).
        Each stiffness is added to the diagonal of the global stiffness.

    Notes
    -----
    Every method that takes displacements ``u``, loads or temperature changes
    ``dT`` accepts one load case (1-D arrays) or several cases as columns
    (``u`` of shape (n_dof, n_cases), ``dT`` of shape (n_bars, n_cases)). A
    scalar ``dT`` is a uniform temperature change.

    Examples
    --------
    A 1 m bar is pinned at node 0 and slides along its axis at node 1. Under
    dT = 10 degC it expands freely and carries no force.

    >>> bar = Truss([[0, 0], [1000, 0]], [[0, 1]], E=70e3, A=100,
    ...             alpha=23e-6, supports=[0, 1, 3])
    >>> u = bar.solve(dT=10.0)
    >>> round(float(u[2]), 4)
    0.23
    >>> float(bar.bar_forces(u, dT=10.0)[0])
    0.0
    """

    def __init__(self, nodes, bars, *, E, A, alpha=0.0, supports=(), springs=None):
        nodes = np.asarray(nodes, dtype=float)
        if nodes.ndim != 2 or nodes.shape[1] != 2 or not np.all(np.isfinite(nodes)):
            raise ValueError("nodes must be a finite array of shape (n_nodes, 2).")
        bars = np.asarray(bars)
        if (
            bars.ndim != 2
            or bars.shape[1] != 2
            or bars.shape[0] == 0
            or not np.issubdtype(bars.dtype, np.integer)
        ):
            raise ValueError("bars must be an integer array of shape (n_bars, 2).")
        if bars.min() < 0 or bars.max() >= len(nodes):
            raise ValueError("bars refers to a node index outside nodes.")
        self.nodes = nodes
        self.bars = bars.astype(np.intp)
        self.E = self._per_bar(E, "E", positive=True)
        self.A = self._per_bar(A, "A", positive=True)
        self.alpha = self._per_bar(alpha, "alpha", positive=False)

        delta = nodes[self.bars[:, 1]] - nodes[self.bars[:, 0]]
        self.lengths = np.hypot(delta[:, 0], delta[:, 1])
        if np.any(self.lengths <= 0.0):
            raise ValueError("bars must connect two distinct node positions.")
        self.cosines = delta / self.lengths[:, None]
        # Row b of _B maps the 4 dofs of bar b to its elongation.
        self._B = np.hstack([-self.cosines, self.cosines])
        i, j = self.bars[:, 0], self.bars[:, 1]
        self._dofs = np.column_stack([2 * i, 2 * i + 1, 2 * j, 2 * j + 1])

        supports = np.unique(np.asarray(supports, dtype=np.intp).ravel())
        if supports.size and (supports.min() < 0 or supports.max() >= self.n_dof):
            raise ValueError("supports contains a dof outside 0..2*n_nodes-1.")
        self.supports = supports
        self.free_dofs = np.setdiff1d(np.arange(self.n_dof), supports)

        axial = self.E * self.A / self.lengths
        k_bars = axial[:, None, None] * self._B[:, :, None] * self._B[:, None, :]
        K = np.zeros((self.n_dof, self.n_dof))
        np.add.at(K, (self._dofs[:, :, None], self._dofs[:, None, :]), k_bars)
        self._K_bars = K
        self.spring_dofs, self.spring_stiffness = self._check_springs(springs)

    # ------------------------------------------------------------------ set-up
    @property
    def n_nodes(self):
        return len(self.nodes)

    @property
    def n_bars(self):
        return len(self.bars)

    @property
    def n_dof(self):
        return 2 * self.n_nodes

    def _per_bar(self, value, name, *, positive):
        value = np.asarray(value, dtype=float)
        if value.ndim == 0:
            value = np.full(self.n_bars, float(value))
        if value.shape != (self.n_bars,) or not np.all(np.isfinite(value)):
            raise ValueError(f"{name} must be a finite scalar or one value per bar.")
        if positive and np.any(value <= 0.0):
            raise ValueError(f"{name} must be positive for every bar.")
        return value

    def _check_springs(self, springs):
        if not springs:
            return np.zeros(0, dtype=np.intp), np.zeros(0)
        dofs = np.asarray(list(springs.keys()), dtype=np.intp)
        stiffness = np.asarray(list(springs.values()), dtype=float)
        if dofs.min() < 0 or dofs.max() >= self.n_dof:
            raise ValueError("springs contains a dof outside 0..2*n_nodes-1.")
        if not np.all(np.isfinite(stiffness)) or np.any(stiffness < 0.0):
            raise ValueError("spring stiffnesses must be finite and >= 0.")
        return dofs, stiffness

    def with_springs(self, springs):
        """Return a copy of the truss with the springs replaced by ``springs``."""
        new = copy.copy(self)
        new.spring_dofs, new.spring_stiffness = self._check_springs(springs)
        return new

    # ---------------------------------------------------------------- assembly
    def stiffness(self, reduced=False):
        """Global stiffness (N/mm), bars plus springs.

        With ``reduced=True`` only the free (unsupported) dofs are kept. This
        is the matrix that is factorised.
        """
        K = self._K_bars.copy()
        np.add.at(K, (self.spring_dofs, self.spring_dofs), self.spring_stiffness)
        if reduced:
            return K[np.ix_(self.free_dofs, self.free_dofs)]
        return K

    def _bar_field(self, dT):
        """Per-bar temperature change as (n_bars,) or (n_bars, n_cases)."""
        if dT is None:
            return np.zeros(self.n_bars)
        dT = np.asarray(dT, dtype=float)
        if dT.ndim == 0:
            dT = np.full(self.n_bars, float(dT))
        if dT.ndim > 2 or dT.shape[0] != self.n_bars:
            raise ValueError("dT must be a scalar or have n_bars rows.")
        return dT

    def _per_case(self, per_bar, like):
        """Reshape a per-bar vector to broadcast against ``like``."""
        return per_bar.reshape(per_bar.shape + (1,) * (like.ndim - 1))

    def thermal_load(self, dT):
        """Equivalent nodal forces (N) of the temperature changes ``dT``.

        Bar ``b`` adds ``+E A alpha dT`` along its axis at its end node and
        the opposite force at its start node.
        """
        dT = self._bar_field(dT)
        n0 = self._per_case(self.E * self.A * self.alpha, dT) * dT
        B = self._B if dT.ndim == 1 else self._B[:, :, None]
        contribution = B * n0[:, None]
        f = np.zeros((self.n_dof, *dT.shape[1:]))
        np.add.at(f, self._dofs, contribution)
        return f

    def _rhs(self, loads, dT):
        f = self.thermal_load(dT)
        if loads is not None:
            loads = np.asarray(loads, dtype=float)
            if loads.ndim > 2 or loads.shape[0] != self.n_dof:
                raise ValueError("loads must have 2 * n_nodes rows.")
            if loads.ndim == 2 and f.ndim == 1:
                f = f[:, None]
            elif loads.ndim == 1 and f.ndim == 2:
                loads = loads[:, None]
            f = f + loads
        return f

    # ------------------------------------------------------------------ solve
    def factor(self):
        """Cholesky factor of the reduced stiffness.

        Raises
        ------
        ValueError
            If the structure is a mechanism (singular reduced stiffness).
        """
        K = self.stiffness(reduced=True)
        try:
            factor = linalg.cho_factor(K, lower=True, check_finite=False)
        except linalg.LinAlgError:
            raise ValueError(_MECHANISM_MESSAGE) from None
        pivots = np.diag(factor[0]) ** 2
        if not np.all(np.isfinite(pivots)) or pivots.min() <= (
            _MECHANISM_RTOL * np.abs(np.diag(K)).max()
        ):
            raise ValueError(_MECHANISM_MESSAGE)
        return factor

    def solve(self, loads=None, dT=None):
        """Nodal displacements (mm) under nodal ``loads`` (N) and ``dT``.

        Returns an array of shape (n_dof,) or (n_dof, n_cases). Restrained
        dofs are zero.
        """
        f = self._rhs(loads, dT)
        u = np.zeros_like(f)
        if self.free_dofs.size:
            u[self.free_dofs] = linalg.cho_solve(
                self.factor(), f[self.free_dofs], check_finite=False
            )
        return u

    # ------------------------------------------------------------ recovery
    def elongations(self, u):
        """Bar elongations (mm) from nodal displacements ``u``."""
        return np.einsum("bk,bk...->b...", self._B, np.asarray(u)[self._dofs])

    def total_strains(self, u):
        """Total strain ``elongation / L`` of each bar (thermal + mechanical)."""
        e = self.elongations(u)
        return e / self._per_case(self.lengths, e)

    def bar_strains(self, u, dT=None):
        """Mechanical strain ``elongation / L - alpha dT`` of each bar.

        A temperature-compensated strain gauge reads this strain.
        """
        total = self.total_strains(u)
        dT = self._bar_field(dT)
        if dT.ndim == 2 and total.ndim == 1:
            total = total[:, None]
        return total - self._per_case(self.alpha, dT) * dT

    def bar_forces(self, u, dT=None):
        """Axial force (N) of each bar, tension positive."""
        strain = self.bar_strains(u, dT)
        return self._per_case(self.E * self.A, strain) * strain

    def spring_forces(self, u):
        """Forces (N) exerted by the springs on the nodes, shape of ``u``."""
        u = np.asarray(u, dtype=float)
        f = np.zeros_like(u)
        k = self._per_case(self.spring_stiffness, u)
        np.add.at(f, self.spring_dofs, -k * u[self.spring_dofs])
        return f

    def reactions(self, u, loads=None, dT=None):
        """Support reactions (N) on the nodes, zero at the free dofs.

        Reactions, spring forces and applied loads are in equilibrium.
        """
        r = self.stiffness() @ np.asarray(u, dtype=float) - self._rhs(loads, dT)
        if r.ndim == 2 and np.ndim(u) == 1:
            r = r[:, 0]
        r[self.free_dofs] = 0.0
        return r
