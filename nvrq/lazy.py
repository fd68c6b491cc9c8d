"""Packages that import their public names and their submodules on first use (``import nvrq``
loads nothing heavy, and ``nvrq.sets.kid`` still resolves after a plain ``import nvrq``).

>>> ns = {"__all__": ["sqrt"]}
>>> getattr_, dir_ = lazy_exports("pkg", {"sqrt": "math"}, ns)
>>> getattr_("sqrt")(9.0), "sqrt" in ns, dir_()
(3.0, True, ['__all__', 'sqrt'])
>>> getattr_, _ = lazy_exports("email", {}, {})
>>> getattr_("utils").__name__
'email.utils'
"""

from __future__ import annotations

import importlib
import importlib.util

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: dict[str, str], namespace: dict):
    """A package's module ``__getattr__`` and ``__dir__`` (PEP 562) for lazily imported names
    and submodules: ``package.name`` is ``exports[name]``'s attribute ``name`` or, failing that,
    the submodule ``package.name``, imported on first use.

    Parameters
    ----------
    package : str
        The package's name: its submodules are looked up under it, and an unknown attribute's
        error names it.
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
        if module is not None:
            value = getattr(importlib.import_module(module), name)
        elif not name.startswith("__") and importlib.util.find_spec(f"{package}.{name}") is not None:
            value = importlib.import_module(f"{package}.{name}")
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *namespace.get("__all__", ())})

    return __getattr__, __dir__
