"""The optional bridge to PyIQA: metric columns ``pyiqa:NAME`` computed by ``pyiqa.create_metric(NAME)``.

Used only when the ``pyiqa`` package is importable; it is not part of the default install (it needs
torchvision, and each learned metric needs PyIQA's weights in PyIQA's own cache: this toolkit
never downloads them). Whether a metric is full- or no-reference and its direction are PyIQA's
(``metric_mode``, ``lower_better``; read from ``pyiqa.default_model_configs`` when it has them,
else from the created metric). Full-reference PyIQA metrics get the GT crop and the render crop
resized to its size, as the pixel metrics do; no-reference ones the raw render crop. Crops go to
PyIQA as float tensors (1, 3, H, W) in [0, 1], RGB, on the CPU, one pair at a time.
"""

from __future__ import annotations

import importlib
from functools import cache, partial

import numpy as np

from data_schema.errors import InputError
from nvrq.metrics.info import MetricInfo

__all__ = ["metric_entry", "require_pyiqa", "INSTALL_HINT"]

INSTALL_HINT = ("pyiqa installed for pyiqa: metrics (pip install pyiqa torchvision; PyIQA's weights "
                "must already be in its cache, this toolkit downloads nothing)")


def require_pyiqa(column: str):
    """The ``pyiqa`` module.

    Parameters
    ----------
    column : str
        The column that needs it (named in the error).

    Returns
    -------
    module
        ``pyiqa``.

    Raises
    ------
    InputError
        One line naming ``column`` and what to install, when pyiqa cannot be imported.
    """
    try:
        return importlib.import_module("pyiqa")
    except ImportError as exc:
        raise InputError(param="metrics", field=column, expected=INSTALL_HINT, got=f"{type(exc).__name__}: {exc}") from None


@cache
def _metric(name: str):
    """``pyiqa.create_metric(name)`` on the CPU, created once per process."""
    return require_pyiqa(f"pyiqa:{name}").create_metric(name, device="cpu")


def _mode(pyiqa, name: str) -> tuple[str, bool]:
    """``(metric_mode {'FR', 'NR'}, lower_better)`` of PyIQA metric ``name``."""
    try:
        configs = importlib.import_module("pyiqa.default_model_configs").DEFAULT_CONFIGS
    except (ImportError, AttributeError):
        configs = None
    if configs is not None and name in configs:
        cfg = configs[name]
        return str(cfg.get("metric_mode", "NR")), bool(cfg.get("lower_better", False))
    m = _metric(name)
    return str(m.metric_mode), bool(m.lower_better)


def _tensor(crop: np.ndarray):
    import torch

    return torch.from_numpy(np.ascontiguousarray(crop)).permute(2, 0, 1)[None].float().div(255.0)


def _score(name: str, *crops: np.ndarray) -> float:
    """PyIQA's value for one crop (no reference: ``render``) or pair (``gt, render``)."""
    import torch

    metric = _metric(name)
    tensors = [_tensor(c) for c in crops]
    with torch.no_grad():
        value = metric(tensors[-1], tensors[0]) if len(tensors) == 2 else metric(tensors[0])
    return float(np.asarray(value.detach().cpu() if hasattr(value, "detach") else value).ravel()[0])


@cache
def metric_entry(name: str):
    """The registry entry of the column ``pyiqa:NAME`` (the ``pyiqa`` family's ``members``).

    Parameters
    ----------
    name : str
        A PyIQA metric name (``pyiqa.list_models()``).

    Returns
    -------
    MetricInfo
        Direction and full/no reference as PyIQA declares them; ``fn`` scores one crop or pair.

    Raises
    ------
    InputError
        One line naming the column when pyiqa is not installed or does not know ``name`` (the
        message says how to list its names). Any other failure of pyiqa propagates.
    """
    column = f"pyiqa:{name}"
    pyiqa = require_pyiqa(column)
    known = list(pyiqa.list_models())
    if name not in known:
        raise InputError(param="metrics", field=column, expected="a PyIQA metric name (list them with: python -c "
                         "\"import pyiqa; print(pyiqa.list_models())\")", got=name)
    mode, lower = _mode(pyiqa, name)
    reference = mode.upper() == "FR"
    return MetricInfo(column, not lower, (-float("inf"), float("inf")), fn=partial(_score, name),
                      reference=reference, description=f"PyIQA {name} ({mode}, "
                      f"{'lower' if lower else 'higher'} is better)")
