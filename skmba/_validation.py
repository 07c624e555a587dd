"""Argument checks shared by the estimators, the numerics and the datasets.

One home for the checks that several modules need, so that the same bad
value gets the same message everywhere.

Examples
--------
>>> from skmba._validation import check_count
>>> check_count(3, "n_chains")
3
>>> check_count(0, "burn_in", minimum=0)
0
"""

from numbers import Integral


def check_count(value, name, *, minimum=1):
    """``value`` as an int, or a ValueError naming ``name``.

    Parameters
    ----------
    value : object
        The count to check; ``bool`` is refused (``True`` is not a count).
    name : str
        The argument's name, for the message.
    minimum : int, default=1
        Smallest valid value.

    Returns
    -------
    int

    Raises
    ------
    ValueError
        ``value`` is not an integer or is below ``minimum``.
    """
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise ValueError(f"{name} must be {what}, got {value!r}.")
    return int(value)
