"""The aluminium truss bridge of thesis section 5.2 as a finite element model.

The geometry (an 8-panel Pratt truss with crossed interior panels), the
sections and material, the supports and the horizontal spring ``k`` at the
roller end, the strain gauges, the top-heated temperature profile of the
reality, and the picklable response callables that
:func:`~skmba.datasets.make_truss_bridge` returns as ``simulator`` and
``reality``. The structure, the conventions and the gauge layout are
described in docs/internals.rst, section skmba.datasets._truss_bridge; the
solver is :class:`~skmba.datasets._truss_solver.Truss`.

Examples
--------
>>> from skmba.datasets._truss_bridge_model import (
...     SENSORS, TrussBridgeResponse, bridge_geometry)
>>> nodes, bars, names, kinds = bridge_geometry()
>>> nodes.shape, bars.shape, names.index(SENSORS["SA"])
((16, 2), (35, 2), 0)
>>> model = TrussBridgeResponse([0], profile=[1.0] * 35,
...                             reference_temperature=20.0)
>>> abs(float(model([[30.0]], [[0.0]])[0, 0])) < 1e-9  # free expansion
True
"""

import numpy as np

from skmba.datasets._truss_solver import Truss

__all__ = [
    "N_PANELS",
    "PANEL_LENGTH",
    "SENSORS",
    "THERMAL_EXPANSION",
    "TRUSS_HEIGHT",
    "YOUNGS_MODULUS",
    "AtFixedParameter",
    "TrussBridgeResponse",
    "bridge_geometry",
    "bridge_truss",
    "temperature_profile",
]

# Material of the thesis FE model (section 5.2.2): aluminium.
YOUNGS_MODULUS = 70_000.0  # MPa = N/mm^2
THERMAL_EXPANSION = 23.1e-6  # 1/degC

# Geometry and sections (our choice; see docs/internals.rst, section
# skmba.datasets._truss_bridge).
N_PANELS = 8
PANEL_LENGTH = 400.0  # mm
TRUSS_HEIGHT = 400.0  # mm
CHORD_AREA = 30.0**2 - 26.0**2  # 30x30x2 SHS, mm^2
WEB_AREA = 20.0**2 - 16.0**2  # 20x20x2 SHS, mm^2

# Gauge name -> bar name (see the table in docs/internals.rst, section
# skmba.datasets._truss_bridge).
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


def bridge_geometry():
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


def bridge_truss(k=0.0):
    """The bridge truss with spring ``k`` (N/mm) and the spring's dof."""
    nodes, bars, names, kinds = bridge_geometry()
    chord_like = np.isin(kinds, ["lower chord", "upper chord", "end post"])
    areas = np.where(chord_like, CHORD_AREA, WEB_AREA)
    roller = names.index(f"L{N_PANELS - 1}-L{N_PANELS}")
    roller_node = bars[roller, 1]
    spring_dof = int(2 * roller_node)
    truss = Truss(
        nodes,
        bars,
        E=YOUNGS_MODULUS,
        A=areas,
        alpha=THERMAL_EXPANSION,
        supports=[0, 1, 2 * roller_node + 1],
        springs={spring_dof: float(k)},
    )
    return truss, spring_dof


def temperature_profile(truss, gradient, exponent):
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
    """``a`` as a finite float array of shape (n, 1); a 1-D ``a`` is a column."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] != 1:
        raise ValueError(f"{name} must have shape (n, 1); got {a.shape}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite.")
    return a


class TrussBridgeResponse:
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
        self.truss, self.spring_dof = bridge_truss()
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
        """Gauge strains of shape (n, n_sensors) at temperatures ``X``."""
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


class AtFixedParameter:
    """``g(X) = f(X, theta)`` for a fixed ``theta`` (picklable)."""

    def __init__(self, function, theta):
        self.function = function
        self.theta = np.asarray(theta, dtype=float).reshape(1, -1)

    def __call__(self, X):
        """``function(X, theta)`` at the fixed ``theta``."""
        return self.function(X, self.theta)
