"""Option objects for the public functions that take many options (layer: data_schema, shared by
every stage).

A function with many options takes one frozen dataclass (``options``), built once by its CLI
(``options_from_args``) or by an API caller. Earlier callers passed the options as keywords;
:func:`options_or_keywords` turns that spelling into the same object, so it keeps working.

>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Opts:
...     n: int = 1
...     name: str = "a"
>>> options_or_keywords(Opts, None, {}, who="f")
Opts(n=1, name='a')
>>> options_or_keywords(Opts, None, {"n": 3}, who="f")
Opts(n=3, name='a')
>>> options_or_keywords(Opts, None, {"size": 3}, who="f")
Traceback (most recent call last):
...
TypeError: f() got an unexpected keyword argument 'size'
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

__all__ = ["options_or_keywords"]


def options_or_keywords(cls: type, options: Any, keywords: dict, *, who: str,
                        renames: dict | None = None) -> Any:
    """``options``, or a ``cls`` made from the former keyword arguments ``keywords``.

    Parameters
    ----------
    cls : type
        The frozen options dataclass.
    options : cls or None
        The options object the caller gave (None: the defaults, or ``keywords``).
    keywords : dict
        The former keyword spelling: field names of ``cls`` (or keys of ``renames``).
    who : str
        The function's name, for the error of an unknown keyword.
    renames : dict, optional
        Former keyword -> field name (e.g. ``{'metrics_path': 'metrics_paths'}``).

    Returns
    -------
    cls
        The options.

    Raises
    ------
    TypeError
        Both ``options`` and keywords, or a keyword that is not an option (as Python says it).
    """
    if not keywords:
        return cls() if options is None else options
    if options is not None:
        raise TypeError(f"{who}() takes `options` or the former keyword arguments, not both")
    renames = renames or {}
    names = {f.name for f in fields(cls)}
    values = {}
    for key, value in keywords.items():
        name = renames.get(key, key)
        if name not in names:
            raise TypeError(f"{who}() got an unexpected keyword argument {key!r}")
        values[name] = value
    return cls(**values)
