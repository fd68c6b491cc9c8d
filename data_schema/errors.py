"""One error type for bad user input: it names the file, the field and what was expected.

Layer: data_schema (file formats).

Every command catches :class:`InputError` at the top level, prints ``str(err)`` as one
line and exits with status 2 (docs/FORMATS.md §7; :func:`nvrq.cli_types.run_cli`).

>>> str(InputError("scene.json", "cameras.front.T_sensor_rig", "a 4x4 matrix", "3x4"))
'scene.json: cameras.front.T_sensor_rig: expected a 4x4 matrix, got 3x4'
>>> str(InputError(param="tracks", expected="an integer >= 1", got=0))
'tracks: expected an integer >= 1, got 0'
"""

from __future__ import annotations

import math
import numbers

__all__ = ["InputError", "check_int", "check_number", "check_choice", "shorten", "GOT_CHARS"]

#: the longest ``got`` part of an error line, in characters (longer ones are shortened)
GOT_CHARS = 240


def shorten(text: str, limit: int = GOT_CHARS) -> str:
    """``text`` cut to at most ``limit`` characters at a word boundary, ``" ..."`` marking the cut.

    A word (e.g. a path) is never cut in the middle, unless the first word alone is too long.

    Parameters
    ----------
    text : str
        One line.
    limit : int
        The most characters returned, the mark included (at least 8).

    Returns
    -------
    str
        ``text`` itself when it fits, else its first words and ``" ..."``.

    >>> shorten("6 expected, 0 found (first missing: images/front/0.png)", 40)
    '6 expected, 0 found (first missing ...'
    >>> shorten("short", 40)
    'short'
    """
    if len(text) <= limit:
        return text
    head = text[: limit - 4]  # room for " ..."
    if text[limit - 4] != " " and head.rfind(" ") > 0:
        head = head[: head.rfind(" ")]  # the last word fitting whole
    return head.rstrip(" ,;:") + " ..."


class InputError(ValueError):
    """Bad user input, said in one line.

    Parameters
    ----------
    where : object, optional
        The file (or table, folder, store) the bad value is in; ``None`` when the value came
        from a parameter.
    field : str, optional
        The key, row or column inside it (or the item of a parameter's value).
    expected : str
        What was expected (required).
    got : object, optional
        What was found (``None``: not said). On one line, shortened to :data:`GOT_CHARS`
        characters at a word boundary (:func:`shorten`).
    param : str, optional
        The library parameter (``tracks``) or command-line option (``--tracks``) whose value
        is bad. The CLIs name their flag for a parameter
        (:func:`nvrq.cli_types.flags_in_errors`).

    Notes
    -----
    The message is ``"{where}: {param}: {field}: expected {expected}, got {got}"``, absent
    parts left out. The former positional form ``InputError(where, field, expected, got)``
    with a parameter name as ``where`` still works and prints the same line (its ``param``
    is then None).

    Raises
    ------
    TypeError
        ``expected`` is missing.
    """

    def __init__(self, where: object = None, field: str | None = None, expected: str | None = None,
                 got: object = None, *, param: str | None = None):
        if expected is None:
            raise TypeError("InputError() needs expected")
        self.where = None if where is None else str(where)
        self.param = None if param is None else str(param)
        self.field = field
        self.expected = expected
        self.got = got
        parts = [p for p in (self.where, self.param) if p is not None]
        if field:
            parts.append(str(field))
        msg = ": ".join([*parts, f"expected {expected}"])
        if got is not None:
            msg += f", got {shorten(str(got).replace(chr(10), ' '))}"
        super().__init__(msg)

    def __reduce__(self):
        # pickled with its fields (the default would call InputError(message))
        return (_rebuild, (type(self), self.where, self.field, self.expected, self.got, self.param))


def _rebuild(cls, where, field, expected, got, param):
    return cls(where, field, expected, got, param=param)


def check_int(name: str, value, *, low: int = 1, high: int | None = None) -> int:
    """``value`` when it is an integer (not a bool) in ``[low, high]``: the one check of counts,
    sizes and seeds (library parameters and CLI options).

    Parameters
    ----------
    name : str
        The count, size or seed being checked, e.g. ``"batch_size"``; the error's ``param``.
    value : object
        What the caller passed; ints of any kind (NumPy included) pass, bools never.
    low, high : int, optional
        The bounds, both included (``high=None``: none).

    Returns
    -------
    int

    Raises
    ------
    InputError
        ``value`` is not such an integer.

    >>> check_int("batch_size", 32)
    32
    >>> check_int("batch_size", 0)
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: batch_size: expected a positive integer, got 0
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) \
            or value < low or (high is not None and value > high):
        if high is not None:
            expected = f"an integer in [{low}, {high}]"
        else:
            expected = {1: "a positive integer", 0: "a non-negative integer"}.get(low, f"an integer >= {low}")
        raise InputError(param=name, expected=expected, got=value)
    return int(value)


def check_number(name: str, value, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False) -> float:
    """``value`` as a float when it is a finite real number (not a bool) within the bounds
    ``low``/``high`` (None: none; excluded when ``low_open``/``high_open``), else an
    :class:`InputError` whose ``param`` is ``name`` (as :func:`check_int`).

    Parameters
    ----------
    name : str
        The option being checked, e.g. ``"tau"``; the error's ``param``.
    value : object
        What the caller passed; any finite real (int, float, NumPy scalar) but a bool passes.
    low, high : float, optional
        The bounds (``None``: none).
    low_open, high_open : bool, optional
        Exclude ``low`` / ``high`` themselves.

    Returns
    -------
    float

    Raises
    ------
    InputError
        ``value`` is not such a number.

    >>> check_number("tau", 1.0, low=0, high=1, low_open=True, high_open=True)
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: tau: expected a number in (0, 1), got 1.0
    """
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(value)
    if ok and low is not None:
        ok = value > low if low_open else value >= low
    if ok and high is not None:
        ok = value < high if high_open else value <= high
    if not ok:
        if low == 0 and high is None:
            expected = "a positive number" if low_open else "a non-negative number"
        elif low is not None and high is not None:
            expected = f"a number in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        elif low is not None:
            expected = f"a number {'>' if low_open else '>='} {low:g}"
        elif high is not None:
            expected = f"a number {'<' if high_open else '<='} {high:g}"
        else:
            expected = "a finite number"
        raise InputError(param=name, expected=expected, got=value)
    return float(value)


def check_choice(name: str, value, choices):
    """``value`` when it is one of ``choices``, else an :class:`InputError` whose ``param`` is
    ``name``, listing them.

    Parameters
    ----------
    name : str
        The option being checked, e.g. ``"rank_by"``; the error's ``param``.
    value : object
        What the caller passed; compared with ``in choices``.
    choices : collection
        The allowed values, listed in the error.

    Returns
    -------
    object
        ``value`` itself.

    Raises
    ------
    InputError
        ``value`` is not one of ``choices``.

    >>> check_choice("rank_by", "auc", ("srcc", "plcc"))
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: rank_by: expected one of {'srcc', 'plcc'}, got 'auc'
    """
    if value not in choices:
        raise InputError(param=name, expected="one of {" + ", ".join(map(repr, choices)) + "}", got=repr(value))
    return value

