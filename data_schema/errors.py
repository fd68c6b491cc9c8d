"""One error type for bad user input: it names the file, the field and what was expected.

Every command catches :class:`InputError` at the top level, prints ``str(err)`` as one
line and exits with status 2 (docs/FORMATS.md §7; :func:`nvrq.commands.args.run_cli`).

>>> str(InputError("scene.json", "cameras.front.T_sensor_rig", "a 4x4 matrix", "3x4"))
'scene.json: cameras.front.T_sensor_rig: expected a 4x4 matrix, got 3x4'
"""

from __future__ import annotations

import math
import numbers

__all__ = ["InputError", "check_int", "check_number"]


class InputError(ValueError):
    """Bad user input. ``where`` is a file (or option), ``field`` the key/row/column inside it.

    The message is a single line: ``"{where}: {field}: expected {expected}, got {got}"``.
    """

    def __init__(self, where: object, field: str | None, expected: str, got: object = None):
        self.where = str(where)
        self.field = field
        self.expected = expected
        self.got = got
        parts = [self.where]
        if field:
            parts.append(str(field))
        msg = ": ".join(parts) + f": expected {expected}"
        if got is not None:
            got_s = str(got).replace("\n", " ")
            if len(got_s) > 120:
                got_s = got_s[:117] + "..."
            msg += f", got {got_s}"
        super().__init__(msg)


def check_int(name: str, value, *, low: int = 1, high: int | None = None) -> int:
    """``value`` when it is an integer (not a bool) in ``[low, high]``, else an :class:`InputError`
    naming ``name``: the one check of counts, sizes and seeds (library parameters and CLI options).

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
        raise InputError(name, None, expected, value)
    return int(value)


def check_number(name: str, value, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False) -> float:
    """``value`` when it is a finite real number (not a bool) within the bounds (``low``/``high``,
    excluded when ``low_open``/``high_open``), else an :class:`InputError` naming ``name``.

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
        raise InputError(name, None, expected, value)
    return float(value)
