"""The monitored bridge in OpenSees: the same deck, a real finite element engine.

:class:`OpenSeesBridgeModel` is :class:`~skmba.datasets.BridgeModel`
(same parameters, same definition) solved by OpenSeesPy instead of numpy:
``elasticBeamColumn`` elements with their consistent mass (``-cMass``),
the horizontal dof of every node fixed (so that no axial mode enters the
spectrum), the bearings on vertical ``zeroLength`` springs, and
``ops.eigen`` for the frequencies. OpenSees keeps its model in global
state, so every analysis runs in a joblib worker process of its own
(:func:`opensees_frequencies`), never in the calling process; an analysis
that fails returns NaN, which the calibrator records in
``simulation_failures_``.

OpenSeesPy is an optional dependency: ``pip install "skmba[opensees]"``;
on Linux it needs the system BLAS and LAPACK (Debian's ``libblas3`` and
``liblapack3``).

Examples
--------
``tests/datasets/test_bridge_opensees.py`` checks the frequencies against
:class:`~skmba.datasets.BridgeModel` and the failures against the
calibrator; ``examples/plot_bridge_opensees.py`` calibrates with it.
"""

import math
import os
import time
from dataclasses import dataclass

import numpy as np
from joblib.externals.loky import ProcessPoolExecutor

from skmba.datasets._bridge_model import BridgeModel

#: What to install for :class:`OpenSeesBridgeModel`.
OPENSEES_EXTRA = (
    'pip install "skmba[opensees]" (on Linux OpenSeesPy also needs the system '
    "BLAS and LAPACK: apt-get install libblas3 liblapack3)"
)
#: Cross-section area [m^2] given to the elements: the horizontal dofs are
#: fixed, so it changes nothing but must be positive.
_AREA = 1.0
#: States per worker task (each task builds and solves its models in turn).
TASK_STATES = 16


def check_opensees():
    """The ``openseespy.opensees`` module, or an ImportError naming the fix."""
    try:
        import openseespy.opensees as ops
    except (ImportError, RuntimeError) as error:  # RuntimeError: no BLAS/LAPACK
        raise ImportError(
            f"OpenSeesBridgeModel needs OpenSeesPy, an optional dependency of "
            f"skmba: {OPENSEES_EXTRA}. ({type(error).__name__}: {error})"
        ) from error
    return ops


def _build_deck(ops, deck, EI, k_bearing):
    """The deck of ``deck`` (a :class:`~skmba.datasets.BridgeModel`) at the
    rigidity ``EI`` [N m^2] on bearings ``k_bearing`` [N/m] (inf: pinned),
    in OpenSees' basic 2-D frame model (tags from 1)."""
    n, h = deck.n_elements, deck.span / deck.n_elements
    pinned = math.isinf(k_bearing)
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for i in range(n + 1):
        ops.node(i + 1, i * h, 0.0)
        end = i in (0, n)
        ops.fix(i + 1, 1, int(end and pinned), 0)  # horizontal dofs fixed
    if not pinned:
        ops.uniaxialMaterial("Elastic", 1, float(k_bearing))
        for j, i in enumerate((0, n)):
            ground = n + 2 + j
            ops.node(ground, i * h, 0.0)
            ops.fix(ground, 1, 1, 1)
            ops.element("zeroLength", n + 1 + j, ground, i + 1, "-mat", 1, "-dir", 2)
    ops.geomTransf("Linear", 1)
    E = float(EI) / deck.second_moment
    for e in range(n):
        ops.element(
            "elasticBeamColumn", e + 1, e + 1, e + 2, _AREA, E,
            deck.second_moment, 1, "-mass", deck.mass_per_length, "-cMass",
        )  # fmt: skip


def opensees_frequencies(states, deck):
    """Frequencies [Hz] (s, n_modes) and seconds (s,) of the states
    ``(EI, k_bearing)`` (s, 2), each solved by OpenSees in this process (a
    worker's: OpenSees keeps its model in global state, wiped before and
    after each); a row of NaN where the analysis fails or gives a
    non-positive eigenvalue."""
    ops = check_opensees()
    out = np.full((len(states), deck.n_modes), np.nan)
    seconds = np.zeros(len(states))
    for row, (EI, k_bearing) in enumerate(states):
        started = time.perf_counter()
        try:
            ops.wipe()
            ops.logFile(os.devnull, "-noEcho")
            _build_deck(ops, deck, EI, k_bearing)
            values = np.asarray(ops.eigen("-fullGenLapack", deck.n_modes), float)
        except Exception:  # a failed analysis is a result: NaN, recorded by fit
            values = np.zeros(0)
        finally:
            ops.wipe()
        if len(values) == deck.n_modes and np.all(values > 0):
            out[row] = np.sqrt(values) / (2.0 * np.pi)
        seconds[row] = time.perf_counter() - started
    return out, seconds


@dataclass(frozen=True, kw_only=True)
class OpenSeesBridgeModel(BridgeModel):
    """:class:`~skmba.datasets.BridgeModel` solved by OpenSeesPy (the simulator).

    The same deck, parameters and definition as :class:`BridgeModel` (its
    Notes), built with OpenSees' ``elasticBeamColumn`` elements (consistent
    mass, ``-cMass``), the horizontal dof of every node fixed, the bearings
    on vertical ``zeroLength`` springs (pinned ends for ``k_bearing=inf``),
    and solved by ``ops.eigen("-fullGenLapack", n_modes)``: its frequencies
    agree with :class:`BridgeModel`'s to about 1e-10. Every analysis runs in
    a worker process (joblib's loky, a pool of the call's own), never in the
    calling process, whose own
    OpenSees model, if any, is left alone; an analysis that fails gives a
    row of NaN, which :class:`~skmba.ModularBayesCalibrator` records in
    ``simulation_failures_``.

    Parameters
    ----------
    n_jobs : int, default=1
        Worker processes (``-1`` or None: all cores). :meth:`timed_states`
        gives the time of each analysis.
    n_modes, n_elements, span, second_moment, mass_per_length, \
            reference_temperature, temperature_coefficient
        As in :class:`BridgeModel`.

    See Also
    --------
    BridgeModel : the same deck in numpy.
    make_bridge_monitoring : the readings of that deck.

    Notes
    -----
    OpenSeesPy is an optional dependency: ``pip install "skmba[opensees]"``;
    on Linux it needs the system BLAS and LAPACK (Debian's ``libblas3`` and
    ``liblapack3``). Without them the first call raises an ImportError that
    says so.

    Examples
    --------
    >>> from skmba.datasets import OpenSeesBridgeModel
    >>> OpenSeesBridgeModel(n_modes=2, n_jobs=2).n_jobs
    2
    """

    n_jobs: int | None = 1

    def _frequencies(self, EI, k_bearing, element_factors=None):
        return self.timed_states(np.column_stack([EI, k_bearing]))[0]

    def timed_states(self, states):
        """Frequencies (s, n_modes) and seconds per analysis (s,) of the
        states ``(EI, k_bearing)``, in the worker processes."""
        check_opensees()  # the ImportError here, not in a worker
        states = np.asarray(states, dtype=float)
        unique, inverse = np.unique(states, axis=0, return_inverse=True)
        step = TASK_STATES
        chunks = [unique[i : i + step] for i in range(0, len(unique), step)]
        workers = os.cpu_count() if self.n_jobs in (None, -1) else self.n_jobs
        deck = BridgeModel(**{f: getattr(self, f) for f in _DECK_FIELDS})
        # An executor of its own, shut down after the call: joblib's reusable
        # one is joblib's to configure (its workers' thread limits).
        with ProcessPoolExecutor(max_workers=max(1, int(workers))) as executor:
            parts = list(
                executor.map(opensees_frequencies, chunks, [deck] * len(chunks))
            )
        f = np.concatenate([p[0] for p in parts])[inverse.ravel()]
        seconds = np.concatenate([p[1] for p in parts])
        return f, seconds


_DECK_FIELDS = (
    "n_modes",
    "n_elements",
    "span",
    "second_moment",
    "mass_per_length",
    "reference_temperature",
    "temperature_coefficient",
)
