"""Named columns: pandas DataFrames matched by name, arrays by position.

Monitoring data come as tables with named sensors, and the simulations as
tables of their own whose columns need not be in the same order. The
estimators read the names here: :func:`column_names` of a table,
:func:`match_columns` reorders a table's columns to those of another (or
says which names are missing and which unknown), :func:`parameters_last`
finds the parameter columns of the designer's ``X`` by name, and
:func:`response_index` finds a response by name or index.

Examples
--------
>>> import numpy as np
>>> match_columns(np.eye(2), ["a", "b"], "X_sim", "X").tolist()
[[1.0, 0.0], [0.0, 1.0]]
>>> response_index("energy", ["tip", "energy"], 2)
1
"""


def column_names(A):
    """The column names of a pandas DataFrame ``A`` (as strings), else None."""
    columns = getattr(A, "columns", None)
    if columns is None or getattr(A, "ndim", 2) != 2:
        return None
    return [str(c) for c in columns]


def match_columns(A, names, name, reference):
    """``A`` with its columns in the order of ``names``, when both are named.

    A DataFrame ``A`` whose columns are a permutation of ``names`` is
    reordered; an array, or ``names`` None, is left as it is (matched by
    position). Different sets of names are a ValueError naming ``name``
    (the argument) and ``reference`` (where ``names`` come from), with the
    missing and the unknown names.
    """
    own = column_names(A)
    if own is None or names is None:
        return A
    names = [str(n) for n in names]
    if len(set(own)) != len(own):
        repeated = sorted({n for n in own if own.count(n) > 1})
        raise ValueError(
            f"{name} has repeated column names {repeated}: each column must "
            "name one variable."
        )
    if set(own) != set(names):
        missing = [n for n in names if n not in own]
        unknown = [n for n in own if n not in names]
        raise ValueError(
            f"The columns of {name} do not match {reference}: {name} lacks "
            f"{missing} and has {unknown} besides ({reference}: {names}; "
            f"{name}: {own}). Name the columns alike (their order may "
            "differ), or pass arrays, which are matched by position."
        )
    return A.iloc[:, [own.index(n) for n in names]]


def parameters_last(X, parameters):
    """A table ``X`` with the columns named in ``parameters`` moved to its end.

    The sensor designer's ``X`` holds the design variables, then the
    calibration parameters. With a DataFrame and named parameters (a dict
    prior), the parameter columns are found by name, whatever their place;
    the other columns, in their order, are the design variables. An array,
    or unnamed parameters, are left as they are (positions).

    Examples
    --------
    >>> import pandas as pd
    >>> X = pd.DataFrame({"E": [70.0], "F": [1.0], "M": [2.0]})
    >>> list(parameters_last(X, ["E"]).columns)
    ['F', 'M', 'E']
    """
    own = column_names(X)
    if own is None or parameters is None:
        return X
    parameters = [str(p) for p in parameters]
    missing = [p for p in parameters if p not in own]
    if missing:
        raise ValueError(
            f"X has no column for the parameter(s) {missing} of the prior "
            f"(its keys: {parameters}; the columns of X: {own}). Name the "
            "parameter columns of X like the prior's keys, or pass X as an "
            "array with the parameters as its last columns."
        )
    design = [c for c in own if c not in parameters]
    return X.iloc[:, [own.index(c) for c in design + parameters]]


def response_index(item, names, q):
    """A response's 0-based index from its index or its name in ``names``."""
    if isinstance(item, str):
        if names is None:
            raise ValueError(
                f"response {item!r} given by name, but the estimator was fitted "
                "on an array y without names: pass 0-based indices, or fit "
                "with y as a pandas DataFrame whose columns name the responses."
            )
        if item not in names:
            raise ValueError(
                f"unknown response {item!r}; the responses are {list(names)}."
            )
        return names.index(item)
    index = int(item)
    if not 0 <= index < q:
        raise ValueError(
            f"response index {index} is out of range for {q} responses (0-based)."
        )
    return index
