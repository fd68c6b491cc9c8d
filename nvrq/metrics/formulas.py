"""The NVRQ formulas (paper Eq. 4, 5): pure functions of embeddings and similarities.

The pixel metrics live in :mod:`nvrq.metrics.pixel`; how crops become embeddings is
:mod:`nvrq.scoring.core`. :func:`check_tau` is the one check of a ``tau`` value, called where
one enters (the resolution rule, argument > user config > registry, is
:func:`nvrq.metrics.tau_config.require_tau`).

NVRQ (Eq. 4): ``S = (cos(f_gt, f_render) + 1) / 2``. NVRQ-CA (Eq. 5): ``S / tau * w`` for
``S < tau``, else ``w + (1 - w) * ((S - tau) / (1 - tau))**2``, ``w = W_LOW = 0.1``.

>>> import numpy as np
>>> nvrq_ca(np.array([0.0, 0.325, 0.65, 1.0]), tau=0.65).round(4).tolist()
[0.0, 0.05, 0.1, 1.0]
"""

from __future__ import annotations

import numpy as np

from data_schema.errors import InputError

__all__ = ["W_LOW", "nvrq_similarity", "nvrq_ca", "check_tau"]

#: NVRQ-CA's value at the knee ``tau`` (paper Eq. 5)
W_LOW = 0.1


def nvrq_similarity(f_gt: np.ndarray, f_render: np.ndarray) -> np.ndarray:
    """Paper Eq. 4: ``(cos + 1) / 2`` row-wise.

    Parameters
    ----------
    f_gt, f_render : (N, D) array
        Embeddings of the GT and render crops, row ``k`` of each for pair ``k``.

    Returns
    -------
    (N,) float64
        S in [0, 1] (NaN where an embedding is all zero).

    >>> nvrq_similarity(np.array([[1.0, 0.0], [1.0, 0.0]]), np.array([[2.0, 0.0], [-1.0, 0.0]])).tolist()
    [1.0, 0.0]
    """
    a = np.asarray(f_gt, np.float64)
    b = np.asarray(f_render, np.float64)
    denom = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.einsum("nd,nd->n", a, b) / denom
    return np.clip((cos + 1.0) / 2.0, 0.0, 1.0)


def nvrq_ca(s: np.ndarray, *, tau: float, w_low: float = W_LOW) -> np.ndarray:
    """Paper Eq. 5, curve-adjusted NVRQ.

    Parameters
    ----------
    s : (N,) array
        NVRQ values S (Eq. 4).
    tau : float
        The knee, in (0, 1).
    w_low : float
        The value at the knee (default :data:`W_LOW`).

    Returns
    -------
    (N,) float64

    Raises
    ------
    InputError
        Naming ``tau`` unless it is a number in (0, 1) (:func:`check_tau`).

    >>> nvrq_ca(np.array([0.0, 0.325, 0.65, 1.0]), tau=0.65).round(4).tolist()
    [0.0, 0.05, 0.1, 1.0]
    """
    check_tau(tau)
    return _nvrq_ca(s, tau, w_low)


def _nvrq_ca(s: np.ndarray, tau: float, w_low: float = W_LOW) -> np.ndarray:
    """:func:`nvrq_ca` without the tau check (the scoring plan checks tau once per run)."""
    s = np.asarray(s, np.float64)
    low = s / tau * w_low
    high = w_low + (1.0 - w_low) * ((s - tau) / (1.0 - tau)) ** 2
    return np.where(s < tau, low, high)


def _nvrq(s: np.ndarray, tau: float | None = None) -> np.ndarray:
    """NVRQ's column from the similarities ``s`` (N,): ``s`` itself (paper Eq. 4; ``tau`` unused)."""
    return np.asarray(s, np.float64)


def check_tau(tau, *, where: object = "tau", field: str | None = None) -> None:
    """The one check of an NVRQ-CA knee ``tau``.

    Parameters
    ----------
    tau : object
        The value to check.
    where, field : optional
        What the error names: the parameter ``tau`` (default), or e.g. a config file and its key.

    Raises
    ------
    InputError
        Unless ``tau`` is a number (not a bool) strictly between 0 and 1.

    >>> check_tau(1.5)
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: tau: expected a number strictly between 0 and 1 (NVRQ-CA knee; `nvrq calibrate-tau` measures one), got 1.5
    """
    if tau is None or isinstance(tau, bool) or not isinstance(tau, (int, float, np.integer, np.floating)) \
            or not 0.0 < tau < 1.0:
        raise InputError(where, field, "a number strictly between 0 and 1 (NVRQ-CA knee; "
                         "`nvrq calibrate-tau` measures one)", tau)
