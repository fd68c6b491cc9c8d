"""Packages that import their public names on first use (``import nvrq`` loads nothing heavy).

>>> ns = {"__all__": ["sqrt"]}
>>> getattr_, dir_ = lazy_exports("pkg", {"sqrt": "math"}, ns)
>>> getattr_("sqrt")(9.0), "sqrt" in ns, dir_()
(3.0, True, ['__all__', 'sqrt'])
"""

from __future__ import annotations

import importlib

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: dict[str, str], namespace: dict):
    """A package's module ``__getattr__`` and ``__dir__`` (PEP 562) for lazily imported names.

    Parameters
    ----------
    package : str
        The package's name, for the error of an unknown attribute.
    exports : dict
        Public name -> the module defining it.
    namespace : dict
        The package's ``globals()``: a name, once imported, is stored there (later look-ups
        skip ``__getattr__``); its ``__all__`` is listed by ``__dir__``.

    Returns
    -------
    tuple of callable
        ``(__getattr__, __dir__)``.
    """

    def __getattr__(name: str):
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *namespace.get("__all__", ())})

    return __getattr__, __dir__
