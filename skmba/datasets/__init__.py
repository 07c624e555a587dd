"""Reference problems of the thesis as dataset generators.

* :func:`make_cantilever`: the cantilever beam of thesis sections 4.7 and
  6.3 (closed-form beam theory; the model has a fixed support, reality a
  rotational spring).
* :func:`make_truss_bridge`: a 2-D truss finite element model in the spirit
  of the aluminium bridge of thesis sections 5.2 and 6.4 (thermal loading,
  a horizontal spring as the parameter, strain gauges as responses).
* :func:`make_bridge_monitoring`: a year of hourly natural frequencies of a
  concrete bridge deck (beam finite elements, modal analysis) against the
  air temperature, stiffening below freezing, with outages and an optional
  damage event; :class:`OpenSeesBridgeModel`, its simulator solved by
  OpenSeesPy (optional extra ``skmba[opensees]``).

Examples
--------
>>> from skmba.datasets import (
...     make_bridge_monitoring, make_cantilever, make_truss_bridge)
>>> make_cantilever(random_state=0).y_sim.shape
(70, 2)
>>> make_truss_bridge(10, 5, sensors=["SA"], random_state=0).y_obs.shape
(5, 1)
>>> make_bridge_monitoring(24, 5, random_state=0).y_obs.shape
(24, 4)
"""

from skmba.datasets._bridge_model import BridgeModel, BridgeReality, youngs_modulus_at
from skmba.datasets._bridge_monitoring import make_bridge_monitoring
from skmba.datasets._bridge_opensees import OpenSeesBridgeModel
from skmba.datasets._cantilever import make_cantilever
from skmba.datasets._cantilever_model import CantileverModel, CantileverReality
from skmba.datasets._truss_bridge import make_truss_bridge

__all__ = [
    "BridgeModel",
    "BridgeReality",
    "CantileverModel",
    "CantileverReality",
    "OpenSeesBridgeModel",
    "make_bridge_monitoring",
    "make_cantilever",
    "make_truss_bridge",
    "youngs_modulus_at",
]
