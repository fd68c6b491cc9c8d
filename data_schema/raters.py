"""Rater ids (docs/FORMATS.md §5, ``ratings.csv`` column ``rater_id``): their form and the
prefix reserved for simulated raters, shared by the rater app, the simulator and analysis.

Layer: data_schema (file formats).

>>> check_rater_name("ann.b")
'ann.b'
>>> check_rater_name("sim-1")
Traceback (most recent call last):
...
data_schema.errors.InputError: rater: name: expected a name not starting with 'sim-' (reserved for simulated raters), got sim-1
"""

from __future__ import annotations

import re

from data_schema.errors import InputError

__all__ = ["SIM_PREFIX", "check_rater_name"]

#: Rater ids of simulated raters start with this; people cannot sign in with it.
SIM_PREFIX = "sim-"

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,39}$")


def check_rater_name(name: str, *, allow_sim: bool = False) -> str:
    """A rater id: 1-40 of ``A-Z a-z 0-9 _ . -`` starting alphanumeric; ``sim-*`` is reserved
    unless ``allow_sim``. Returns the stripped name; raises :class:`InputError` otherwise.

    Parameters
    ----------
    name : str
        The rater id to check.
    allow_sim : bool, optional
        Accept the ``sim-`` prefix (the simulator's raters).

    Returns
    -------
    str
        The stripped name.

    Raises
    ------
    InputError
        A name of another form.
    """
    name = str(name).strip()
    if not _NAME.match(name):
        raise InputError("rater", "name", "1-40 letters, digits, '_', '.', '-'", repr(name))
    if name.lower().startswith(SIM_PREFIX) and not allow_sim:
        raise InputError("rater", "name",
                         f"a name not starting with {SIM_PREFIX!r} (reserved for simulated raters)", name)
    return name
