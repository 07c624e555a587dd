"""The one way skmba warns: at the user's line, whatever the depth.

:func:`warn` issues a warning attributed to the first frame outside the
``skmba`` package (the user's script, a test, or the library that called
skmba, such as scikit-learn's ``GridSearchCV``), so that no call site
counts frames by hand and a new layer of functions cannot point a warning
at the wrong line.

Examples
--------
>>> import warnings
>>> from skmba._core.warn import warn
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     warn("a message")
>>> caught[0].filename.startswith("<doctest")  # this example, not skmba
True
"""

import os
import sys
import warnings

#: The folder of the package: frames in files below it are skmba's own.
PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep


def user_stacklevel():
    """The ``stacklevel`` of the first frame outside skmba, for a warning
    issued by the caller of this function."""
    frame = sys._getframe(2)  # the caller of the function that asked
    level = 2
    while frame is not None and frame.f_code.co_filename.startswith(PACKAGE_DIR):
        frame = frame.f_back
        level += 1
    return level


def warn(message, category=UserWarning):
    """Issue ``message`` as ``category``, attributed to the user's frame."""
    warnings.warn(message, category, stacklevel=user_stacklevel())
