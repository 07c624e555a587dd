"""Reference problems of the thesis as dataset generators.

* :func:`make_cantilever`: the cantilever beam of thesis sections 4.7 and
  6.3 (closed-form beam theory; the model has a fixed support, reality a
  rotational spring).
* :func:`make_truss_bridge`: a 2-D truss finite element model in the spirit
  of the aluminium bridge of thesis sections 5.2 and 6.4 (thermal loading,
  a horizontal spring as the parameter, strain gauges as responses).
"""

from skmba.datasets._cantilever import (
    CantileverModel,
    CantileverReality,
    make_cantilever,
)
from skmba.datasets._truss_bridge import make_truss_bridge

__all__ = [
    "CantileverModel",
    "CantileverReality",
    "make_cantilever",
    "make_truss_bridge",
]
