"""Latent render quality of each object: severity in [0, 1] and per-artefact strengths.

Layer: nvrq core, synth (synthetic scenes).

A reconstruction degrades as the virtual camera leaves the training trajectory. Here the
severity of an object grows with the lateral offset ``|y|`` at a per-object rate set by
its training-view ``coverage`` (objects seen in few views break down early) and with the
viewing-angle change ``atan(|y| / depth)`` (near objects change most):

    severity = s0 + (1 - s0) * (1 - exp(-(rate * |y| + 1.2 * atan(|y| / max(depth, 2)))))
    rate = 0.06 + 0.5 * (1 - coverage),   s0 = 0.02 + 0.05 * (1 - coverage)

so the 0 m render is close to, not equal to, the GT. A view moved along other axes uses,
instead of ``|y|``, the perturbation's size (:func:`perturbation_size`):
``|dx| + |dy| + |dz| + M_PER_DEG * (|roll| + |pitch| + |yaw|)``, so 5 deg of rotation
degrade like 1 m of shift; for a lateral view it is exactly ``|y|``. Each artefact's strength is the
severity times the object's artefact profile (weights in [0.25, 1], max 1).

Worked example, coverage 1 at 3 m and 10 m depth: x = 0.06 * 3 + 1.2 * atan(0.3) = 0.5298,
severity = 0.02 + 0.98 * (1 - exp(-0.5298)) = 0.4230.

>>> np.round(severity(np.array([0.0, 3.0]), np.array([10.0, 10.0]), coverage=1.0), 4).tolist()
[0.02, 0.423]
"""

from __future__ import annotations

import numpy as np

__all__ = ["severity", "strengths", "perturbation_size", "M_PER_DEG"]

#: Degradation-equivalent metres of one degree of rotation (synthetic model only).
M_PER_DEG = 0.2


def perturbation_size(perturbations: np.ndarray) -> np.ndarray:
    """``(K, 6)`` perturbations -> size ``(K,)`` (module docstring).

    Parameters
    ----------
    perturbations : (K, 6) float64
        ``(dx, dy, dz, roll, pitch, yaw)``: metres, degrees, rig frame.

    Returns
    -------
    (K,) float64, metres
        ``|dx| + |dy| + |dz| + M_PER_DEG * (|roll| + |pitch| + |yaw|)``.

    >>> perturbation_size(np.array([[0, -2.0, 0, 0, 0, 0], [0, 0, 0.5, 0, 0, -5.0]])).tolist()
    [2.0, 1.5]
    """
    P = np.abs(np.asarray(perturbations, float).reshape(-1, 6))
    return P[:, 0] + P[:, 1] + P[:, 2] + M_PER_DEG * (P[:, 3] + P[:, 4] + P[:, 5])


def severity(abs_offset: np.ndarray, depth: np.ndarray, *, coverage: float) -> np.ndarray:
    """``abs_offset, depth: (N,)`` metres -> severity ``(N,)`` in [0, 1] (module docstring).

    Parameters
    ----------
    abs_offset : (N,) float64, metres
        Size of the perturbation (``|y|`` for a lateral view).
    depth : (N,) float64, metres
        Object depth in the camera.
    coverage : float
        The object's training-view coverage in (0, 1].

    Returns
    -------
    (N,) float64
        Severity in [0, 1].
    """
    y = np.abs(np.asarray(abs_offset, float))
    rate = 0.06 + 0.5 * (1.0 - coverage)
    s0 = 0.02 + 0.05 * (1.0 - coverage)
    x = rate * y + 1.2 * np.arctan(y / np.maximum(np.asarray(depth, float), 2.0))
    return np.clip(s0 + (1.0 - s0) * (1.0 - np.exp(-x)), 0.0, 1.0)


def strengths(sev: np.ndarray, profile: np.ndarray) -> np.ndarray:
    """``sev (N,)``, ``profile (6,)`` -> artefact strengths ``(N, 6)`` in [0, 1].

    Parameters
    ----------
    sev : (N,) float64
        Severities in [0, 1].
    profile : (6,) float64
        The object's artefact weights in [0.25, 1].

    Returns
    -------
    (N, 6) float64
        Artefact strengths in [0, 1].
    """
    return np.clip(np.asarray(sev, float)[:, None] * np.asarray(profile, float)[None, :], 0.0, 1.0)
