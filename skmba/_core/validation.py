"""Argument checks shared by the estimators, the numerics and the datasets.

One home for the checks that several modules need, so that the same bad
value gets the same message everywhere.

Constructor parameters are checked from a table: an estimator declares the
class attribute ``_parameter_table`` (a name of its own: scikit-learn's
``_parameter_constraints`` is read by scikit-learn's own validation, which
expects its own schema), a dict mapping every parameter of
``get_params(deep=False)`` to a list of constraints (or to
``"no_validation"`` when it is checked later, with the data), and calls
:func:`validate_parameter_table` at the start of ``fit``. A value is valid
when one constraint of its list accepts it. The constraints are
:class:`Options`, :class:`Count`, :class:`Real`, :class:`Boolean`,
:class:`InstanceOf`, :class:`Callable` and :class:`NJobs`; see
``MultiResponseGP._parameter_table`` for a table.

scikit-learn's ``sklearn.utils._param_validation`` is private and words its
messages its own way ("The 'alpha' parameter of ... must be a float in the
range [0.0, inf). Got -1.0 instead."), not in the wording (and hints) that
skmba's users and tests rely on; hence this small local module. As there,
:class:`InvalidParameterError` is both a ``ValueError`` and a ``TypeError``:
a value of the wrong type and one out of range are caught alike.

Examples
--------
>>> from skmba import MultiResponseGP
>>> from skmba._core.validation import Count, check_count, validate_parameter_table
>>> check_count(0, "burn_in", minimum=0)
0
>>> Count(minimum=2, allow_none=True).message("n_design", 1)
'n_design must be an integer >= 2 or None, got 1.'
>>> try:
...     gp = MultiResponseGP(noise="yes")
...     validate_parameter_table(gp._parameter_table, gp.get_params(), "GP")
... except ValueError as exc:
...     print(exc)
noise must be True or False, got 'yes'.
"""

from numbers import Integral
from numbers import Real as _RealNumber

import numpy as np
from sklearn.utils import check_random_state

NO_VALIDATION = "no_validation"


class InvalidParameterError(ValueError, TypeError):
    """A parameter of the wrong type or out of range (a ValueError and a TypeError)."""


def _is_int(value):
    return isinstance(value, Integral) and not isinstance(value, bool)


def _join(terms):
    """``"a, b or c"`` from ``["a", "b", "c"]``."""
    return terms[0] if len(terms) == 1 else f"{', '.join(terms[:-1])} or {terms[-1]}"


class _Constraint:
    """One accepted kind of value: ``phrase`` (for messages) and ``_accepts``.

    ``hint`` is added in parentheses after the phrase; ``allow_none`` also
    accepts None (and the message says "or None").
    """

    phrase = ""

    def __init__(self, *, hint=None, allow_none=False):
        self.hint = hint
        self.allow_none = allow_none

    def _accepts(self, value):
        raise NotImplementedError

    def accepts(self, value):
        """Whether ``value`` satisfies this constraint."""
        return self.allow_none if value is None else bool(self._accepts(value))

    def terms(self):
        """The alternatives this constraint accepts, for a message."""
        hint = f" ({self.hint})" if self.hint else ""
        return [self.phrase + hint] + (["None"] if self.allow_none else [])

    def got(self, value):
        """How a refused value is shown."""
        return repr(value)

    def message(self, name, value):
        """The error message for a refused ``value`` of parameter ``name``."""
        return f"{name} must be {_join(self.terms())}, got {self.got(value)}."


class Options(_Constraint):
    """One of the strings ``options``.

    >>> Options(("exhaustive", "greedy")).message("search", "random")
    "search='random' is not supported; use one of 'exhaustive', 'greedy'."
    """

    def __init__(self, options, *, hint=None, allow_none=False):
        super().__init__(hint=hint, allow_none=allow_none)
        self.options = tuple(options)
        names = ", ".join(repr(option) for option in self.options)
        self.phrase = names if len(self.options) == 1 else f"one of {names}"

    def _accepts(self, value):
        return isinstance(value, str) and value in self.options

    def message(self, name, value):
        return f"{name}={value!r} is not supported; use {_join(self.terms())}."


class Count(_Constraint):
    """An integer (not a bool) ``>= minimum``."""

    def __init__(self, *, minimum=1, hint=None, allow_none=False):
        super().__init__(hint=hint, allow_none=allow_none)
        self.minimum = minimum
        self.phrase = {1: "a positive integer", 0: "a non-negative integer"}.get(
            minimum, f"an integer >= {minimum}"
        )

    def _accepts(self, value):
        return _is_int(value) and value >= self.minimum


class Real(_Constraint):
    """A real number (not a bool), finite if ``finite``, ``>= minimum`` and
    ``<= maximum`` if given.

    >>> Real(minimum=0, hint="the nugget, e.g. 1e-10").message("alpha", -1.0)
    'alpha must be a finite float >= 0 (the nugget, e.g. 1e-10), got -1.0.'
    >>> Real(minimum=0, maximum=1).message("rate", 1.5)
    'rate must be a finite float in [0, 1], got 1.5.'
    """

    def __init__(
        self, *, minimum=None, maximum=None, finite=True, hint=None, allow_none=False
    ):
        super().__init__(hint=hint, allow_none=allow_none)
        self.minimum = minimum
        self.maximum = maximum
        self.finite = finite
        if minimum is not None and maximum is not None:
            bound = f" in [{minimum:g}, {maximum:g}]"
        elif maximum is not None:
            bound = f" <= {maximum:g}"
        else:
            bound = "" if minimum is None else f" >= {minimum:g}"
        self.phrase = ("a finite float" if finite else "a float") + bound

    def _accepts(self, value):
        return (
            isinstance(value, _RealNumber)
            and not isinstance(value, bool)
            and (not self.finite or np.isfinite(value))
            and (self.minimum is None or value >= self.minimum)
            and (self.maximum is None or value <= self.maximum)
        )


class Boolean(_Constraint):
    """``True`` or ``False`` (Python or numpy bool)."""

    phrase = "True or False"

    def _accepts(self, value):
        return isinstance(value, bool | np.bool_)


class InstanceOf(_Constraint):
    """An instance of ``cls``, described as ``what`` (default "a <cls name>").

    Refused values are shown by their type name.
    """

    def __init__(self, cls, *, what=None, hint=None, allow_none=False):
        super().__init__(hint=hint, allow_none=allow_none)
        self.cls = cls
        self.phrase = what or f"a {cls.__name__}"

    def _accepts(self, value):
        return isinstance(value, self.cls)

    def got(self, value):
        return type(value).__name__


class Callable(InstanceOf):
    """A callable, described as ``what`` (default "a callable").

    >>> Callable(what="a callable f(X, theta) -> Y").message("simulator", 3)
    'simulator must be a callable f(X, theta) -> Y, got int.'
    """

    def __init__(self, *, what="a callable", hint=None, allow_none=False):
        super().__init__(object, what=what, hint=hint, allow_none=allow_none)

    def _accepts(self, value):
        return callable(value)


class NJobs(_Constraint):
    """joblib's ``n_jobs``: None or a non-zero integer (-1: all cores)."""

    phrase = (
        "None, a positive integer (number of parallel tasks) or a negative one "
        "(-1: all cores)"
    )

    def accepts(self, value):
        return value is None or (_is_int(value) and value != 0)


def validate_parameter_table(table, params, owner):
    """Check the parameters ``params`` (``get_params(deep=False)``) of the
    class named ``owner`` against its table ``table`` (``_parameter_table``).

    Every parameter needs an entry (a list of constraints, or
    ``"no_validation"``), else a ``RuntimeError`` (a bug of the estimator).
    In the order of the table, the first parameter that no constraint of its
    list accepts raises an :class:`InvalidParameterError` with that
    constraint's message, or with several constraints "name=value is not
    supported; use a, b or c."
    """
    missing = sorted(set(params) - set(table))
    if missing:
        raise RuntimeError(
            f"{owner}._parameter_table has no entry for {missing}; add one "
            "(or 'no_validation')."
        )
    for name, constraints in table.items():
        value = params[name]
        if constraints == NO_VALIDATION or any(c.accepts(value) for c in constraints):
            continue
        if len(constraints) == 1:
            raise InvalidParameterError(constraints[0].message(name, value))
        terms = _join([term for c in constraints for term in c.terms()])
        raise InvalidParameterError(f"{name}={value!r} is not supported; use {terms}.")


def check_count(value, name, *, minimum=1):
    """``value`` (an integer >= ``minimum``, not a bool) as an int.

    Raises an :class:`InvalidParameterError` (a ``ValueError``) naming
    ``name`` otherwise.
    """
    count = Count(minimum=minimum)
    if not count.accepts(value):
        raise InvalidParameterError(count.message(name, value))
    return int(value)


def seed_sequence(random_state):
    """The package's one way from ``random_state`` to random numbers.

    Every random step of an estimator draws from its own child of one
    :class:`numpy.random.SeedSequence` (``spawn``), so that the steps are
    independent and the result does not depend on the order in which
    parallel tasks run.

    Parameters
    ----------
    random_state : None, int, RandomState, Generator or SeedSequence
        An int (>= 0) is the entropy as is; a ``RandomState`` or
        ``Generator`` gives one random integer; a ``SeedSequence`` is used as
        is; None draws fresh entropy.

    Returns
    -------
    numpy.random.SeedSequence

    Examples
    --------
    >>> seed_sequence(3).entropy
    3
    """
    if random_state is None:
        return np.random.SeedSequence()
    if isinstance(random_state, np.random.SeedSequence):
        return random_state
    if isinstance(random_state, np.random.Generator):
        return np.random.SeedSequence(int(random_state.integers(2**63)))
    if isinstance(random_state, np.random.RandomState):
        return np.random.SeedSequence(int(random_state.randint(2**63, dtype=np.int64)))
    if _is_int(random_state) and random_state >= 0:
        return np.random.SeedSequence(int(random_state))
    raise InvalidParameterError(
        "random_state must be None, a non-negative int, a numpy RandomState, a "
        f"numpy Generator or a SeedSequence, got {random_state!r}."
    )


def random_state_instance(random_state):
    """A :class:`numpy.random.RandomState` for the code that needs one.

    scikit-learn's ``check_random_state`` for None, an int or a
    ``RandomState`` (the same numbers as before); a ``Generator`` or a
    ``SeedSequence`` seeds a new ``RandomState`` through
    :func:`seed_sequence`, so that two fresh Generators of one seed give
    the same result.

    Examples
    --------
    >>> a = random_state_instance(np.random.default_rng(0)).uniform()
    >>> a == random_state_instance(np.random.default_rng(0)).uniform()
    True
    """
    if isinstance(random_state, (np.random.Generator, np.random.SeedSequence)):
        return np.random.RandomState(int_seed(seed_sequence(random_state)))
    return check_random_state(random_state)


def int_seed(sequence):
    """A 32-bit integer seed from a :class:`numpy.random.SeedSequence`.

    For the APIs that take an int seed (scikit-learn's ``random_state``,
    scipy's quasi-Monte Carlo engines).

    Examples
    --------
    >>> int_seed(np.random.SeedSequence(0)) == int_seed(np.random.SeedSequence(0))
    True
    """
    return int(sequence.generate_state(1)[0])
