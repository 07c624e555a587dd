"""Aluminium truss bridge under thermal loading (thesis section 5.2 and 6.4).

A reduced-scale aluminium truss bridge is heated from above. A pair of
linear springs restrains the horizontal movement of one of its ends, and their
stiffness ``k`` is the parameter to calibrate from strain-gauge readings taken
at different temperatures. This module provides a small finite element model
of such a bridge and a dataset generator, :func:`make_truss_bridge`, built on
it.

Structure
---------
The figure of the laboratory bridge (thesis Fig. 5.4) is not available in
text form, so the geometry below is our own choice, sized like a
laboratory model. It is a parallel-chord Pratt truss of eight 400 mm panels
(span 3200 mm, depth 400 mm) with inclined end posts and crossed diagonals
(both diagonals) in the six interior panels. The diagonals of a panel are
not connected where they cross::

           U1      U2      U3      U4      U5      U6      U7
            o-------o-------o-------o-------o-------o-------o
          / | \\   / | \\   / | \\   / | \\   / | \\   / | \\   / | \\
        /   |   X   |   X   |   X   |   X   |   X   |   X   |   \\
      /     | /   \\ | /   \\ | /   \\ | /   \\ | /   \\ | /   \\ |     \\
    o-------o-------o-------o-------o-------o-------o-------o-------o--/\\/\\/--|
    L0     L1      L2      L3      L4      L5      L6      L7      L8    k
    ^ pin                                                          o roller

16 nodes (lower chord ``L0``-``L8``, upper chord ``U1``-``U7``) and 35 bars.
``L0`` is pinned. ``L8`` sits on a roller (restrained vertically), and a
horizontal spring of stiffness ``k`` connects it to the abutment. The
supports are statically determinate. The crossed panels make the truss
internally indeterminate six times, so a non-uniform temperature field stresses
it even when ``k = 0``.

Members are square hollow sections of aluminium 6082-T6. Chords and end
posts are 30x30x2 mm (A = 224 mm^2); verticals and diagonals are 20x20x2 mm
(A = 144 mm^2). The material constants are those of the thesis FE model:
E = 70 GPa and alpha = 23.1e-6 /degC.

Units and sign conventions
--------------------------
Forces are in N, lengths in mm, stresses and E in MPa (N/mm^2), stiffnesses in
N/mm, temperatures in degC. ``x`` points along the span from ``L0`` to ``L8``
and ``y`` points up. Nodal displacements and loads are positive along ``x``
and ``y``. Global dof ``2 i`` is the ``x`` dof of node ``i`` and
``2 i + 1`` its ``y`` dof. Bar forces and strains are positive in tension.
A positive temperature change means heating. Responses are strains in
microstrain (1e-6).

Thermal load and strain gauges
------------------------------
Take a bar of length ``L`` with temperature change ``dT``. It would expand
freely by ``alpha dT L``. In the stiffness method this becomes a pair of
equivalent nodal forces ``+-E A alpha dT`` along the bar axis, pushing its
end nodes apart. From the nodal displacements the bar's total strain is its
elongation divided by ``L``. Its mechanical (stress-producing) strain is
``elongation / L - alpha dT``, and its axial force is ``E A`` times the
mechanical strain.

The gauges on the bridge are temperature compensated for aluminium, and the
thesis removes their remaining thermal output in post-processing. Such a
gauge reads the **mechanical** strain: it reads zero on a bar that expands
freely. The gauges are also taken to be zeroed at the reference
temperature ``T_ref = 20 degC`` (thesis section 5.2.2). The dead load
therefore cancels (the model is linear), and every response is linear in
``T - T_ref``.

Model and reality
-----------------
The model (the simulator) follows the thesis FE model. It applies the
measured temperature ``T`` uniformly to every bar. A uniform temperature
change leaves any truss stress-free when its supports are statically
determinate, so every strain in the model comes from the spring force. This
force restrains the expansion of the lower chord::

    F_s = k K_t / (k + K_t) * alpha (T - T_ref) * span,

where ``K_t`` is the horizontal stiffness of the truss at the roller.
Every model strain is this one force times a fixed influence coefficient.
The model's gauge readings are therefore exactly proportional to one
another, ``y_m(T, k) = (T - T_ref) s(k) w`` for a fixed vector ``w``. The
thesis FE model has the same property (one spring force, uniform
temperature, linear elasticity). It matters for emulators: a noise-free
multi-response Gaussian process fitted to several gauges of ``y_sim`` has a
singular response covariance. Fit such an emulator with a noise term, or
emulate one gauge at a time.

In reality (the laboratory experiment) the heaters are above the bridge and
its top is hotter than its bottom. In the thesis, ``T`` is the temperature
measured at the top of the bridge. We therefore give reality the following
temperature change at relative height ``eta = y / h``::

    dT(eta) = (T - T_ref) * [(1 - g) + g * eta**p],

averaged along each bar. The upper chord gets the full ``T - T_ref``, the
lower chord ``(1 - g)`` of it, and verticals and diagonals values in between.
``g`` is the ``gradient`` factor and ``p`` the ``gradient_exponent``. This
temperature field is the model discrepancy: with ``g = 0`` reality and model
coincide.

The default is ``p = 2``: the temperature drops faster than linearly
below the irradiated upper chord. The choice matters. A temperature field
that is linear in the coordinates (``p = 1``) leaves any truss free of
internal stress. Reality is then just the model times ``(1 - g)`` (a
smaller spring force), the same factor at every gauge, and the discrepancy
is indistinguishable from a change of ``k``. With ``p != 1`` the crossed
panels develop self-stresses, and each gauge sees its own discrepancy. The
real bridge behaved like this: at some gauges the strain trend had opposite
signs in model and experiment (thesis section 5.2.4). Reality is still
linear in ``T - T_ref`` at fixed ``k``, so its noise-free readings are
proportional across gauges too, but along a different vector than the
model's.

Strain gauges
-------------
The thesis had eleven gauges ``SA``-``SK`` (section 5.2). Nine of them,
``SA``-``SI``, were used in the sensor-design study of section 6.4. The
text places ``A`` and ``E`` near the bridge ends. It places ``B`` and ``G``
one at the top and one at the bottom, and ``H`` and ``I`` at the centre.
We keep these names and hints and choose the rest:

====  ========  ==========================================
Name  Bar       Position
====  ========  ==========================================
SA    L0-L1     lower chord, end panel at the pinned support
SB    U2-U3     upper chord, third panel
SC    U2-L3     diagonal, third panel
SD    L2-U2     vertical, second panel point
SE    L7-U7     vertical next to the spring end
SF    L5-U6     diagonal, sixth panel
SG    L3-L4     lower chord, fourth panel
SH    U4-U5     upper chord, mid-span
SI    L4-L5     lower chord, mid-span
SJ    L4-U4     vertical, mid-span
SK    U4-L5     diagonal, fifth panel (mid-span)
====  ========  ==========================================
"""

import copy
import numbers

import numpy as np
from scipy import linalg, stats
from sklearn.utils import Bunch

from skmba.datasets._design import as_generator, latin_hypercube, per_response

__all__ = ["make_truss_bridge"]

# Material of the thesis FE model (section 5.2.2): aluminium.
YOUNGS_MODULUS = 70_000.0  # MPa = N/mm^2
THERMAL_EXPANSION = 23.1e-6  # 1/degC
REFERENCE_TEMPERATURE = 20.0  # degC, T_0 of section 5.2.2

# Geometry and sections (our choice; see the module docstring).
N_PANELS = 8
PANEL_LENGTH = 400.0  # mm
TRUSS_HEIGHT = 400.0  # mm
CHORD_AREA = 30.0**2 - 26.0**2  # 30x30x2 SHS, mm^2
WEB_AREA = 20.0**2 - 16.0**2  # 20x20x2 SHS, mm^2

# Spring rate given by the supplier (thesis Table 5.1), N/mm.
NOMINAL_SPRING_STIFFNESS = 552.26
# Prior range of thesis Table 5.2, N/mm.
STIFFNESS_RANGE = (300.0, 1000.0)
# Temperature range of thesis Table 5.2, degC.
TEMPERATURE_RANGE = (20.19, 45.49)

# Gauge name -> bar name (see the table in the module docstring).
SENSORS = {
    "SA": "L0-L1",
    "SB": "U2-U3",
    "SC": "U2-L3",
    "SD": "L2-U2",
    "SE": "L7-U7",
    "SF": "L5-U6",
    "SG": "L3-L4",
    "SH": "U4-U5",
    "SI": "L4-L5",
    "SJ": "L4-U4",
    "SK": "U4-L5",
}

# Relative pivot below which the reduced stiffness is declared singular.
_MECHANISM_RTOL = 1e-10

_MECHANISM_MESSAGE = (
    "The truss is a mechanism: its stiffness matrix, with supports and springs "
    "applied, is singular. Add supports, springs or bars so that every free "
    "degree of freedom is restrained."
)


class _Truss:
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

    >>> bar = _Truss([[0, 0], [1000, 0]], [[0, 1]], E=70e3, A=100,
    ...              alpha=23e-6, supports=[0, 1, 3])
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


# --------------------------------------------------------------------- bridge
def _bridge_geometry():
    """Nodes, bars, bar names and bar kinds of the bridge truss."""
    n = N_PANELS
    index = {}
    coords = []
    for i in range(n + 1):
        index[f"L{i}"] = len(coords)
        coords.append((i * PANEL_LENGTH, 0.0))
    for i in range(1, n):
        index[f"U{i}"] = len(coords)
        coords.append((i * PANEL_LENGTH, TRUSS_HEIGHT))

    members = []
    members += [(f"L{i}", f"L{i + 1}", "lower chord") for i in range(n)]
    members += [(f"U{i}", f"U{i + 1}", "upper chord") for i in range(1, n - 1)]
    members += [("L0", "U1", "end post"), (f"U{n - 1}", f"L{n}", "end post")]
    members += [(f"L{i}", f"U{i}", "vertical") for i in range(1, n)]
    for i in range(1, n - 1):
        # Pratt diagonal (descending towards mid-span), then the crossing one.
        if i < n // 2:
            members += [(f"U{i}", f"L{i + 1}", "diagonal")]
            members += [(f"L{i}", f"U{i + 1}", "diagonal")]
        else:
            members += [(f"L{i}", f"U{i + 1}", "diagonal")]
            members += [(f"U{i}", f"L{i + 1}", "diagonal")]

    nodes = np.array(coords)
    bars = np.array([(index[a], index[b]) for a, b, _ in members], dtype=np.intp)
    names = [f"{a}-{b}" for a, b, _ in members]
    kinds = [kind for _, _, kind in members]
    return nodes, bars, names, kinds


def _bridge_truss(k=0.0):
    """The bridge truss with spring ``k`` (N/mm) and the spring's dof."""
    nodes, bars, names, kinds = _bridge_geometry()
    chord_like = np.isin(kinds, ["lower chord", "upper chord", "end post"])
    areas = np.where(chord_like, CHORD_AREA, WEB_AREA)
    roller = names.index(f"L{N_PANELS - 1}-L{N_PANELS}")
    roller_node = bars[roller, 1]
    spring_dof = int(2 * roller_node)
    truss = _Truss(
        nodes,
        bars,
        E=YOUNGS_MODULUS,
        A=areas,
        alpha=THERMAL_EXPANSION,
        supports=[0, 1, 2 * roller_node + 1],
        springs={spring_dof: float(k)},
    )
    return truss, spring_dof


def _temperature_profile(truss, gradient, exponent):
    """Per-bar factor on ``T - T_ref`` for the top-heated bridge.

    The temperature change at relative height ``eta`` is
    ``(1 - g) + g * eta**p``. Each bar gets its mean along the bar.
    """
    y = truss.nodes[:, 1]
    eta = (y - y.min()) / (y.max() - y.min())
    ends = eta[truss.bars]
    lo, hi = ends.min(axis=1), ends.max(axis=1)
    span = hi - lo
    inclined = span > 0.0
    mean_power = lo**exponent
    mean_power[inclined] = (
        hi[inclined] ** (exponent + 1) - lo[inclined] ** (exponent + 1)
    ) / ((exponent + 1) * span[inclined])
    return (1.0 - gradient) + gradient * mean_power


def _as_column(a, name):
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] != 1:
        raise ValueError(f"{name} must have shape (n, 1); got {a.shape}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite.")
    return a


class _TrussBridgeResponse:
    """Gauge strains (microstrain) of the bridge, ``f(X, theta) -> Y``.

    ``X`` (n, 1) is the temperature (degC), ``theta`` (n, 1) the spring
    stiffness (N/mm, >= 0). Both are read row by row, and a single
    ``theta`` row is broadcast over ``X``. Bar ``b`` gets the temperature
    change ``(T - T_ref) * profile[b]``: a profile of ones is the uniform
    field of the model. The response is linear in ``T - T_ref``, so each
    distinct ``k`` costs one Cholesky factorisation and one solve for a unit
    temperature change.
    """

    def __init__(self, sensor_bars, profile, reference_temperature):
        self.truss, self.spring_dof = _bridge_truss()
        self.sensor_bars = np.asarray(sensor_bars, dtype=np.intp)
        self.profile = np.asarray(profile, dtype=float)
        self.reference_temperature = float(reference_temperature)

    def unit_response(self, k):
        """Gauge strains (microstrain) per degC of ``T - T_ref`` at stiffness ``k``."""
        truss = self.truss.with_springs({self.spring_dof: float(k)})
        u = truss.solve(dT=self.profile)
        strain = truss.bar_strains(u, dT=self.profile)
        return 1e6 * strain[self.sensor_bars]

    def __call__(self, X, theta):
        X = _as_column(X, "X")
        theta = _as_column(theta, "theta")
        if theta.shape[0] == 1:
            theta = np.repeat(theta, X.shape[0], axis=0)
        if theta.shape[0] != X.shape[0]:
            raise ValueError(
                f"X and theta must have the same number of rows; got {X.shape[0]} "
                f"and {theta.shape[0]}."
            )
        if np.any(theta < 0.0):
            raise ValueError("theta (spring stiffness, N/mm) must be >= 0.")
        stiffness, inverse = np.unique(theta[:, 0], return_inverse=True)
        unit = np.array([self.unit_response(k) for k in stiffness])
        unit = unit.reshape(len(stiffness), self.sensor_bars.size)
        return (X - self.reference_temperature) * unit[inverse.ravel()]


class _AtFixedParameter:
    """``g(X) = f(X, theta)`` for a fixed ``theta`` (picklable)."""

    def __init__(self, function, theta):
        self.function = function
        self.theta = np.asarray(theta, dtype=float).reshape(1, -1)

    def __call__(self, X):
        return self.function(X, self.theta)


# ------------------------------------------------------------- validation
def _check_count(value, name):
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Integral)
        or int(value) < 1
    ):
        raise ValueError(f"{name} must be a positive integer; got {value!r}.")
    return int(value)


def _check_positive(value, name):
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number; got {value!r}.") from None
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be a positive finite number; got {value!r}.")
    return value


def _check_sensors(sensors):
    names = list(SENSORS)
    if sensors is None:
        return names
    if isinstance(sensors, (str, numbers.Integral)):
        sensors = [sensors]
    try:
        sensors = list(sensors)
    except TypeError:
        raise ValueError(
            f"sensors must be None, a gauge name, an index or a list of them; "
            f"got {sensors!r}."
        ) from None
    if not sensors:
        raise ValueError(f"sensors must not be empty; choose among {names}.")
    chosen = []
    for s in sensors:
        if isinstance(s, str):
            if s not in SENSORS:
                raise ValueError(
                    f"sensors: unknown gauge {s!r}; valid names are {names}."
                )
            chosen.append(s)
        elif isinstance(s, numbers.Integral) and not isinstance(s, bool):
            if not 0 <= int(s) < len(names):
                raise ValueError(
                    f"sensors: index {s} out of range; use 0..{len(names) - 1} "
                    f"or a name in {names}."
                )
            chosen.append(names[int(s)])
        else:
            raise ValueError(f"sensors: {s!r} is neither a gauge name nor an index.")
    if len(set(chosen)) != len(chosen):
        raise ValueError(f"sensors contains duplicates: {chosen}.")
    return chosen


def _check_prior(prior):
    if prior is None:
        low, high = STIFFNESS_RANGE
        return stats.uniform(loc=low, scale=high - low)
    if not all(callable(getattr(prior, a, None)) for a in ("rvs", "ppf", "support")):
        raise ValueError(
            "stiffness_prior must be a frozen univariate scipy.stats distribution "
            "(with rvs, ppf and support), e.g. scipy.stats.uniform(loc=300, "
            f"scale=700); got {prior!r}."
        )
    try:
        low, high = (float(v) for v in prior.support())
    except (TypeError, ValueError):
        raise ValueError(
            "stiffness_prior must be a univariate distribution whose support() "
            "returns two numbers."
        ) from None
    if not low >= 0.0:
        raise ValueError(
            f"stiffness_prior puts mass on negative spring stiffness (support "
            f"starts at {low}); use a prior on k >= 0, e.g. scipy.stats.uniform, "
            "truncnorm or lognorm."
        )
    return prior


def _check_temperature_range(temperature_range):
    try:
        low, high = (float(v) for v in temperature_range)
    except (TypeError, ValueError):
        raise ValueError(
            "temperature_range must be a pair (T_min, T_max) in degC; got "
            f"{temperature_range!r}."
        ) from None
    if not (np.isfinite(low) and np.isfinite(high) and low < high):
        raise ValueError(
            "temperature_range must be finite with T_min < T_max; got "
            f"{temperature_range!r}."
        )
    return low, high


# ------------------------------------------------------------------ public
def make_truss_bridge(
    n_simulations=60,
    n_observations=30,
    *,
    sensors=None,
    temperature_range=TEMPERATURE_RANGE,
    stiffness_prior=None,
    k_true=NOMINAL_SPRING_STIFFNESS,
    gradient=0.4,
    gradient_exponent=2.0,
    reference_temperature=REFERENCE_TEMPERATURE,
    snr_db=None,
    noise_std=None,
    random_state=None,
):
    """Generate the aluminium truss bridge calibration problem (thesis 5.2, 6.4).

    A simply supported aluminium Pratt truss (8 panels, span 3.2 m) is
    heated. One end is pinned. The other sits on a roller held back by a
    horizontal spring of stiffness ``k``, the calibration parameter. The
    design variable is the temperature ``T`` measured at the top of the
    bridge. The responses are the readings of temperature-compensated strain
    gauges, i.e. the mechanical strains in microstrain, zeroed at
    ``reference_temperature``. The model (``simulator``) heats every bar
    uniformly by ``T - T_ref``. Reality is hotter at the top than at the
    bottom (see ``gradient``), and this is the model discrepancy. See the
    module docstring for the geometry, conventions and gauge layout.

    Parameters
    ----------
    n_simulations : int, default=60
        Number of simulator runs. The design is a Latin hypercube over
        ``temperature_range`` x the prior's quantiles (over its support for a
        uniform prior).
    n_observations : int, default=30
        Number of field observations. Their temperatures are drawn uniformly
        from ``temperature_range`` and sorted, as along a heating cycle.
    sensors : None, str, int or list of str/int, default=None
        Gauges to return, by name (``"SA"`` ... ``"SK"``) or index (0-10).
        None returns all eleven; ``["SA", ..., "SI"]`` are the nine gauges of
        the sensor-design study of thesis section 6.4.
    temperature_range : (float, float), default=(20.19, 45.49)
        Range of ``T`` in degC (thesis Table 5.2).
    stiffness_prior : frozen scipy.stats distribution or None, default=None
        Prior of ``k`` in N/mm with support in ``[0, inf)``. None means
        ``scipy.stats.uniform(loc=300, scale=700)``, i.e. U[300, 1000] N/mm
        as in thesis Table 5.2.
    k_true : float, default=552.26
        True spring stiffness (N/mm), the supplier's rate (thesis Table 5.1).
    gradient : float in [0, 1], default=0.4
        Top-bottom temperature gradient of reality. The upper chord's
        temperature change is ``T - T_ref``, the lower chord's
        ``(1 - gradient) (T - T_ref)``. 0 makes reality equal to the model.
    gradient_exponent : float, default=2.0
        Shape ``p`` of the profile ``(1 - g) + g * eta**p`` over the relative
        height ``eta``. With 1 (linear) reality is the model scaled by
        ``1 - g``, the same factor at every gauge (see module docstring).
    reference_temperature : float, default=20.0
        Temperature (degC) at which the bridge is stress-free and the gauges
        are zeroed (thesis T_0).
    snr_db : float, array-like of shape (n_responses,) or None, default=None
        Signal-to-noise ratio in dB of each response (thesis Eq. 3.34):
        ``SNR_dB = 10 log10(var_signal / var_noise)``. The signal variance
        is that of the noise-free observations of the response.
    noise_std : float, array-like of shape (n_responses,) or None, default=None
        Standard deviation of the Gaussian measurement noise in microstrain.
        Give at most one of ``snr_db`` and ``noise_std``. With neither, the
        observations are noise-free.
    random_state : int, RandomState, Generator or None, default=None
        Seeds the simulation design, the observation temperatures and the
        noise. An int gives reproducible output.

    Returns
    -------
    data : sklearn.utils.Bunch
        With ``q = len(sensors)``:

        - ``X_sim`` (n_simulations, 1): temperatures of the runs (degC).
        - ``theta_sim`` (n_simulations, 1): spring stiffnesses (N/mm).
        - ``y_sim`` (n_simulations, q): model strains (microstrain).
        - ``X_obs`` (n_observations, 1): observed temperatures (degC).
        - ``y_obs`` (n_observations, q): noisy measured strains.
        - ``y_obs_true`` (n_observations, q): noise-free reality.
        - ``theta_true`` (1,): ``[k_true]``.
        - ``prior``: ``[stiffness_prior]``.
        - ``simulator``: picklable callable ``simulator(X, theta) -> Y``
          with ``X`` and ``theta`` of shape (n, 1), read row by row.
        - ``reality``: picklable callable ``reality(X) -> Y`` (true ``k``,
          with the gradient).
        - ``noise_variance`` (q,): variance of the added noise
          (microstrain^2); ``snr_db`` (q,) or None.
        - ``response_names`` (gauge names), ``parameter_names`` (``("k",)``),
          ``design_variable_names`` (``("T",)``), ``response_units``.
        - ``X_bounds`` (1, 2): ``temperature_range``; ``theta_bounds``
          (1, 2): the prior's support.
        - ``nodes`` (16, 2) in mm, ``bars`` (35, 2) node indices,
          ``bar_names``, ``bar_kinds``; ``sensor_bars`` (q,): the bar of
          each gauge.
        - ``reference_temperature``, ``DESCR``.

    Raises
    ------
    ValueError
        On invalid arguments. The message names the argument.

    See Also
    --------
    skmba.ModularBayesCalibrator : calibrates ``k`` from such data.

    Notes
    -----
    Simplifications with respect to the thesis:

    - The thesis FE model (ANSYS) uses beam elements with rotational joint
      stiffness, and its gauges sit on the lower face of the bars. This
      model is pin-jointed and its gauges read the axial strain, so the
      local bending the thesis mentions is absent.
    - The bridge has two truss planes, and each has one spring of the pair at
      the restrained end. The 2-D model is one plane with one spring, so
      ``k`` is the stiffness of a single spring.
    - Friction at the supports, the residual thermal lag of the hollow
      sections (the hysteresis of thesis Fig. 5.5) and the dead load
      (cancelled by zeroing) are not modelled. All responses are exactly
      linear in ``T - T_ref``.
    - The model's gauge strains are proportional to one another (see the
      module docstring). A noise-free emulator of several gauges therefore
      has a singular response covariance and needs a noise term.
      The geometry and sections are our own choice, since Fig. 5.4 is not
      available.

    Examples
    --------
    >>> import numpy as np
    >>> from skmba.datasets import make_truss_bridge
    >>> data = make_truss_bridge(n_simulations=20, n_observations=10,
    ...                          snr_db=30.0, random_state=0)
    >>> data.X_sim.shape, data.theta_sim.shape, data.y_sim.shape
    ((20, 1), (20, 1), (20, 11))
    >>> data.X_obs.shape, data.y_obs.shape, data.theta_true
    ((10, 1), (10, 11), array([552.26]))
    >>> data.response_names[:4], data.bar_names[data.sensor_bars[0]]
    (('SA', 'SB', 'SC', 'SD'), 'L0-L1')

    Model and reality at 40 degC and the true stiffness, gauges SB (upper
    chord) and SG (lower chord): the gradient changes the sign of SB.

    >>> pair = make_truss_bridge(sensors=["SB", "SG"], random_state=0)
    >>> np.round(pair.simulator([[40.0]], [[552.26]]), 1)
    array([[  2.7, -44.2]])
    >>> np.round(pair.reality([[40.0]]), 1)
    array([[ -2. , -29.9]])
    """
    n_simulations = _check_count(n_simulations, "n_simulations")
    n_observations = _check_count(n_observations, "n_observations")
    names = _check_sensors(sensors)
    t_low, t_high = _check_temperature_range(temperature_range)
    prior = _check_prior(stiffness_prior)
    k_true = _check_positive(k_true, "k_true")
    try:
        g = float(gradient)
    except (TypeError, ValueError):
        g = np.nan
    if not 0.0 <= g <= 1.0:
        raise ValueError(f"gradient must be a number in [0, 1]; got {gradient!r}.")
    gradient = g
    gradient_exponent = _check_positive(gradient_exponent, "gradient_exponent")
    try:
        reference_temperature = float(reference_temperature)
    except (TypeError, ValueError):
        reference_temperature = np.nan
    if not np.isfinite(reference_temperature):
        raise ValueError("reference_temperature must be a finite number (degC).")
    if snr_db is not None and noise_std is not None:
        raise ValueError(
            "snr_db and noise_std are mutually exclusive; pass only one of them "
            "(or neither for noise-free observations)."
        )

    truss, _ = _bridge_truss()
    nodes, bars, bar_names, bar_kinds = _bridge_geometry()
    sensor_bars = np.array([bar_names.index(SENSORS[s]) for s in names])
    q = len(names)

    simulator = _TrussBridgeResponse(
        sensor_bars, np.ones(truss.n_bars), reference_temperature
    )
    profile = _temperature_profile(truss, gradient, gradient_exponent)
    reality = _AtFixedParameter(
        _TrussBridgeResponse(sensor_bars, profile, reference_temperature), [k_true]
    )

    rng = as_generator(random_state)
    unit = latin_hypercube(n_simulations, 2, rng)
    X_sim = (t_low + (t_high - t_low) * unit[:, 0])[:, None]
    theta_sim = np.asarray(prior.ppf(unit[:, 1]), dtype=float).reshape(-1, 1)
    y_sim = simulator(X_sim, theta_sim)

    X_obs = np.sort(rng.uniform(t_low, t_high, size=n_observations))[:, None]
    y_obs_true = reality(X_obs)
    snr = None
    if snr_db is not None:
        snr = per_response(snr_db, "snr_db", q, nonnegative=False)
        noise_variance = np.var(y_obs_true, axis=0) / 10.0 ** (snr / 10.0)
    elif noise_std is not None:
        std = per_response(noise_std, "noise_std", q, nonnegative=True)
        noise_variance = std**2
    else:
        noise_variance = np.zeros(q)
    y_obs = y_obs_true + rng.standard_normal(y_obs_true.shape) * np.sqrt(noise_variance)

    layout = "\n".join(
        f"    {s}: bar {SENSORS[s]} ({bar_kinds[b]})"
        for s, b in zip(names, sensor_bars, strict=True)
    )
    descr = (
        "Aluminium truss bridge under thermal loading (thesis sections 5.2, 6.4)\n"
        "-----------------------------------------------------------------------\n"
        f"Pratt truss, {N_PANELS} panels of {PANEL_LENGTH:g} mm, depth "
        f"{TRUSS_HEIGHT:g} mm, crossed interior panels; pinned at L0, roller "
        "with a horizontal spring k at L8.\n"
        f"E = {YOUNGS_MODULUS:g} MPa, alpha = {THERMAL_EXPANSION:g} /degC, "
        f"T_ref = {reference_temperature:g} degC.\n"
        "x: temperature T (degC) at the top of the bridge; theta: spring "
        "stiffness k (N/mm); y: mechanical strain (microstrain) at the gauges\n"
        f"{layout}\n"
        "Model: uniform T - T_ref on all bars. Reality: k = "
        f"{k_true:g} N/mm and top-heated profile (1 - g) + g eta^p with "
        f"g = {gradient:g}, p = {gradient_exponent:g}.\n"
        f"Simulations: {n_simulations} (Latin hypercube); observations: "
        f"{n_observations}; noise variance: {np.round(noise_variance, 4)}.\n"
    )

    return Bunch(
        X_sim=X_sim,
        theta_sim=theta_sim,
        y_sim=y_sim,
        X_obs=X_obs,
        y_obs=y_obs,
        y_obs_true=y_obs_true,
        theta_true=np.array([k_true]),
        prior=[prior],
        simulator=simulator,
        reality=reality,
        noise_variance=noise_variance,
        snr_db=snr,
        response_names=tuple(names),
        parameter_names=("k",),
        design_variable_names=("T",),
        response_units=("microstrain",) * q,
        X_bounds=np.array([[t_low, t_high]]),
        theta_bounds=np.array([[float(v) for v in prior.support()]]),
        nodes=nodes,
        bars=bars,
        bar_names=tuple(bar_names),
        bar_kinds=tuple(bar_kinds),
        sensor_bars=sensor_bars,
        reference_temperature=reference_temperature,
        DESCR=descr,
    )
