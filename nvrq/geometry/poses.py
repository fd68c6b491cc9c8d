"""Rigid poses: quaternions, 4x4 matrices, interpolation and the novel-view offset.

Layer: nvrq core, geometry.

Convention: ``T_a_b`` maps points in frame ``a`` to frame ``b`` (``p_b = T_a_b @ p_a``).
Quaternions are ``[qx, qy, qz, qw]`` (scalar last). Rig frame: x forward, y left, z up.

Worked example: a rig at x = 10 m yawed by +90 degrees (facing +y of the world)
maps its own forward point (1, 0, 0) to the world point (10, 1, 0):

>>> import numpy as np
>>> T = pose7_to_matrix(np.array([10, 0, 0, 0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)]))
>>> np.round(T @ [1, 0, 0, 1], 6).tolist()
[10.0, 1.0, 0.0, 1.0]
"""

from __future__ import annotations

import numpy as np

from data_schema.perturbation import lateral

__all__ = [
    "quat_to_rotmat",
    "rotmat_to_quat",
    "pose7_to_matrix",
    "matrix_to_pose7",
    "invert_rigid",
    "slerp",
    "interpolate_poses",
    "offset_T_sensor_rig",
    "rotation_rpy",
    "perturbation_T",
    "perturb_T_sensor_rig",
    "T_sensor_world",
]


def quat_to_rotmat(q: np.ndarray) -> np.ndarray:
    """Unit quaternions ``q: (..., 4)`` ``[qx, qy, qz, qw]`` -> rotation matrices ``(..., 3, 3)``.

    The quaternion is normalised first (callers validate that its norm is not ~0).

    Parameters
    ----------
    q : (..., 4) float64
        Quaternions ``[qx, qy, qz, qw]``, any non-zero norm.

    Returns
    -------
    (..., 3, 3) float64
        Rotation matrices.
    """
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = np.moveaxis(q, -1, 0)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    R = np.stack(
        [
            1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy),
            2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx),
            2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy),
        ],
        axis=-1,
    )
    return R.reshape(q.shape[:-1] + (3, 3))


def rotmat_to_quat(R: np.ndarray) -> np.ndarray:
    """Rotation matrices ``R: (..., 3, 3)`` -> unit quaternions ``(..., 4)`` ``[qx, qy, qz, qw]``, qw >= 0.

    Shepperd's method, choosing per matrix the numerically largest component.

    Parameters
    ----------
    R : (..., 3, 3) float64
        Rotation matrices.

    Returns
    -------
    (..., 4) float64
        Unit quaternions ``[qx, qy, qz, qw]`` with ``qw >= 0``.

    >>> np.round(rotmat_to_quat(quat_to_rotmat(np.array([0.1, -0.2, 0.3, 0.9]))), 6).tolist()
    [0.102598, -0.205196, 0.307794, 0.923381]
    """
    R = np.asarray(R, dtype=np.float64)
    m = R.reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=-1)
    k = np.argmax(cand, axis=-1)
    q = np.empty((m.shape[0], 4))
    # case w largest
    s = np.sqrt(np.maximum(1.0 + tr, 1e-300)) * 2
    qw = np.stack([(m[:, 2, 1] - m[:, 1, 2]) / s, (m[:, 0, 2] - m[:, 2, 0]) / s,
                   (m[:, 1, 0] - m[:, 0, 1]) / s, 0.25 * s], -1)
    s = np.sqrt(np.maximum(1.0 + m[:, 0, 0] - m[:, 1, 1] - m[:, 2, 2], 1e-300)) * 2
    qx = np.stack([0.25 * s, (m[:, 0, 1] + m[:, 1, 0]) / s, (m[:, 0, 2] + m[:, 2, 0]) / s,
                   (m[:, 2, 1] - m[:, 1, 2]) / s], -1)
    s = np.sqrt(np.maximum(1.0 + m[:, 1, 1] - m[:, 0, 0] - m[:, 2, 2], 1e-300)) * 2
    qy = np.stack([(m[:, 0, 1] + m[:, 1, 0]) / s, 0.25 * s, (m[:, 1, 2] + m[:, 2, 1]) / s,
                   (m[:, 0, 2] - m[:, 2, 0]) / s], -1)
    s = np.sqrt(np.maximum(1.0 + m[:, 2, 2] - m[:, 0, 0] - m[:, 1, 1], 1e-300)) * 2
    qz = np.stack([(m[:, 0, 2] + m[:, 2, 0]) / s, (m[:, 1, 2] + m[:, 2, 1]) / s, 0.25 * s,
                   (m[:, 1, 0] - m[:, 0, 1]) / s], -1)
    q = np.choose(k[:, None], [qw, qx, qy, qz])
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(q[:, 3:4] < 0, -q, q)
    return q.reshape(R.shape[:-2] + (4,))


def pose7_to_matrix(pose: np.ndarray) -> np.ndarray:
    """Poses ``(..., 7)`` ``[x, y, z, qx, qy, qz, qw]`` -> 4x4 transforms ``(..., 4, 4)``.

    Parameters
    ----------
    pose : (..., 7) float64
        ``[x, y, z, qx, qy, qz, qw]``, translation in metres.

    Returns
    -------
    (..., 4, 4) float64
        Rigid transforms.
    """
    pose = np.asarray(pose, dtype=np.float64)
    T = np.zeros(pose.shape[:-1] + (4, 4))
    T[..., :3, :3] = quat_to_rotmat(pose[..., 3:7])
    T[..., :3, 3] = pose[..., :3]
    T[..., 3, 3] = 1.0
    return T


def matrix_to_pose7(T: np.ndarray) -> np.ndarray:
    """4x4 transforms ``(..., 4, 4)`` -> poses ``(..., 7)`` ``[x, y, z, qx, qy, qz, qw]``.

    Parameters
    ----------
    T : (..., 4, 4) float64
        Rigid transforms, translation in metres.

    Returns
    -------
    (..., 7) float64
        ``[x, y, z, qx, qy, qz, qw]``, ``qw >= 0``.
    """
    T = np.asarray(T, dtype=np.float64)
    return np.concatenate([T[..., :3, 3], rotmat_to_quat(T[..., :3, :3])], axis=-1)


def invert_rigid(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms ``(..., 4, 4)`` (``T_a_b`` -> ``T_b_a``), exact for rotations.

    Parameters
    ----------
    T : (..., 4, 4) float64
        Rigid transforms ``T_a_b``.

    Returns
    -------
    (..., 4, 4) float64
        ``T_b_a``.
    """
    T = np.asarray(T, dtype=np.float64)
    R = T[..., :3, :3]
    Rt = np.swapaxes(R, -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions ``(N, 4)`` at fractions ``t: (N,)``.

    Takes the short way round (flips ``q1`` when ``q0 . q1 < 0``).

    Parameters
    ----------
    q0, q1 : (N, 4) float64
        Unit quaternions ``[qx, qy, qz, qw]`` at ``t = 0`` and ``t = 1``.
    t : (N,) float64
        Fractions in ``[0, 1]``.

    Returns
    -------
    (N, 4) float64
        Unit quaternions.
    """
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot).clip(max=1.0)
    theta = np.arccos(dot)
    sin_theta = np.sin(theta)
    small = sin_theta < 1e-9
    safe = np.where(small, 1.0, sin_theta)
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(small, t, np.sin(t * theta) / safe)
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def interpolate_poses(
    timestamps_us: np.ndarray, T_a_b: np.ndarray, query_us: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate poses sampled at ``timestamps_us: (T,)`` (strictly increasing) at ``query_us: (Q,)``.

    Rotation by slerp, translation linearly. Queries outside ``[t_0, t_last]`` are not
    extrapolated: they are flagged invalid and their matrix is the identity.

    Returns ``(T_a_b_q: (Q, 4, 4), valid: (Q,) bool)``.

    Parameters
    ----------
    timestamps_us : (T,) int64, microseconds
        Sample times, strictly increasing.
    T_a_b : (T, 4, 4) float64
        The pose at each sample time.
    query_us : (Q,) int64, microseconds
        Query times.

    Returns
    -------
    T_a_b_q : (Q, 4, 4) float64
        Interpolated poses (identity where invalid).
    valid : (Q,) bool
        Whether the query lies in ``[t_0, t_last]``.

    >>> ts = np.array([0, 100])
    >>> T = np.stack([np.eye(4), pose7_to_matrix(np.array([2., 0, 0, 0, 0, 1, 0]))])
    >>> Tq, ok = interpolate_poses(ts, T, np.array([50, 150]))
    >>> ok.tolist(), np.round(Tq[0, :3, 3], 6).tolist(), float(abs(np.round(Tq[0, 0, 0], 6)))
    ([True, False], [1.0, 0.0, 0.0], 0.0)
    """
    ts = np.asarray(timestamps_us, dtype=np.int64)
    q_us = np.asarray(query_us, dtype=np.int64)
    T_a_b = np.asarray(T_a_b, dtype=np.float64)
    valid = (q_us >= ts[0]) & (q_us <= ts[-1])
    out = np.broadcast_to(np.eye(4), q_us.shape + (4, 4)).copy()
    if not valid.any():
        return out, valid
    qv = q_us[valid]
    if len(ts) == 1:
        out[valid] = T_a_b[0]
        return out, valid
    i1 = np.clip(np.searchsorted(ts, qv, side="right"), 1, len(ts) - 1)
    i0 = i1 - 1
    t = (qv - ts[i0]) / (ts[i1] - ts[i0])
    quats = rotmat_to_quat(T_a_b[:, :3, :3])
    q = slerp(quats[i0], quats[i1], t)
    trans = T_a_b[i0, :3, 3] * (1 - t)[:, None] + T_a_b[i1, :3, 3] * t[:, None]
    Tv = np.zeros((len(qv), 4, 4))
    Tv[:, :3, :3] = quat_to_rotmat(q)
    # exact sample hits keep the stored matrix bit-for-bit
    Tv[:, :3, 3] = trans
    Tv[:, 3, 3] = 1.0
    Tv[t == 0.0] = T_a_b[i0[t == 0.0]]
    Tv[t == 1.0] = T_a_b[i1[t == 1.0]]
    out[valid] = Tv
    return out, valid


def rotation_rpy(roll_deg, pitch_deg, yaw_deg) -> np.ndarray:
    """Rotations ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` ``(..., 3, 3)`` from degrees.

    Convention: rotations about the fixed rig axes (x forward, y left, z up), roll applied
    first, then pitch, then yaw (equivalently intrinsic yaw, pitch', roll''). Right-handed:
    positive yaw turns left (x towards y), positive pitch tilts the view down (x towards
    -z), positive roll lowers the right side (y towards z). Zero angles give exactly ``I``.

    Parameters
    ----------
    roll_deg, pitch_deg, yaw_deg : float or (...,) array, degrees
        Rotations about the rig's x, y and z axes; broadcast together.

    Returns
    -------
    (..., 3, 3) float64
        Rotation matrices.

    >>> np.round(rotation_rpy(0, 0, 90) @ [1, 0, 0], 12).tolist()
    [0.0, 1.0, 0.0]
    >>> np.round(rotation_rpy(0, 90, 0) @ [1, 0, 0], 12).tolist()
    [0.0, 0.0, -1.0]
    """
    r, p, y = (np.radians(np.asarray(a, dtype=np.float64)) for a in (roll_deg, pitch_deg, yaw_deg))
    r, p, y = np.broadcast_arrays(r, p, y)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    one, zero = np.ones_like(r), np.zeros_like(r)
    Rx = np.stack([one, zero, zero, zero, cr, -sr, zero, sr, cr], -1).reshape(r.shape + (3, 3))
    Ry = np.stack([cp, zero, sp, zero, one, zero, -sp, zero, cp], -1).reshape(r.shape + (3, 3))
    Rz = np.stack([cy, -sy, zero, sy, cy, zero, zero, zero, one], -1).reshape(r.shape + (3, 3))
    return Rz @ Ry @ Rx


def perturbation_T(T_sensor_rig: np.ndarray, perturbations: np.ndarray) -> np.ndarray:
    """``T_pert: (K, 4, 4)`` of perturbations ``(K, 6)`` ``(dx, dy, dz, roll, pitch, yaw)``
    (metres, degrees; rig frame) for a sensor mounted at ``T_sensor_rig: (4, 4)``.

    Convention: ``T_pert`` rotates the rig by :func:`rotation_rpy` **about the sensor's
    position** ``c`` (the translation of ``T_sensor_rig``), then translates by
    ``d = (dx, dy, dz)`` in the rig frame: ``p -> R (p - c) + c + d``. So the perturbed
    camera centre is ``c + d`` (a pure yaw does not move it) and its axes are ``R`` times the
    real ones. A pure translation gives ``T_pert = [I | d]`` exactly (paper Eq. 1-2).

    Parameters
    ----------
    T_sensor_rig : (4, 4) float64
        The real camera mounting, sensor frame to rig frame (metres).
    perturbations : (K, 6) float64
        ``(dx, dy, dz, roll, pitch, yaw)``: metres, degrees, rig frame.

    Returns
    -------
    (K, 4, 4) float64
        ``T_pert``, rig frame to (perturbed) rig frame.
    """
    P = np.asarray(perturbations, dtype=np.float64).reshape(-1, 6)
    c = np.asarray(T_sensor_rig, dtype=np.float64)[:3, 3]
    R = rotation_rpy(P[:, 3], P[:, 4], P[:, 5])  # (K, 3, 3); exactly I for zero angles
    T = np.broadcast_to(np.eye(4), (len(P), 4, 4)).copy()
    T[:, :3, :3] = R
    T[:, :3, 3] = P[:, :3] + (c - R @ c)
    return T


def perturb_T_sensor_rig(T_sensor_rig: np.ndarray, perturbations: np.ndarray) -> np.ndarray:
    """Virtual camera mountings ``T_sensor'_rig = T_pert @ T_sensor_rig`` ``(K, 4, 4)`` for
    perturbations ``(K, 6)`` (see :func:`perturbation_T` for the convention).

    Parameters
    ----------
    T_sensor_rig : (4, 4) float64
        The real camera's mounting; the perturbations rotate about its centre.
    perturbations : (K, 6) float64
        One virtual camera per row, as for :func:`perturbation_T`.

    Returns
    -------
    (K, 4, 4) float64
        ``T_sensor'_rig`` of each virtual camera.

    Worked example: a camera at rig (1.5, 0, 1.5) yawed by +90 deg keeps its centre and its
    optical axis (rig +x) turns to rig +y:

    >>> T = np.eye(4); T[:3, 3] = [1.5, 0, 1.5]
    >>> Tp = perturb_T_sensor_rig(T, np.array([[0, 0, 0, 0, 0, 90.0]]))[0]
    >>> np.round(Tp[:3, 3], 12).tolist(), np.round(Tp[:3, 0], 12).tolist()
    ([1.5, 0.0, 1.5], [0.0, 1.0, 0.0])
    """
    T_sensor_rig = np.asarray(T_sensor_rig, dtype=np.float64)
    return perturbation_T(T_sensor_rig, perturbations) @ T_sensor_rig


def offset_T_sensor_rig(T_sensor_rig: np.ndarray, y_offsets_m: np.ndarray) -> np.ndarray:
    """Lateral shorthand of :func:`perturb_T_sensor_rig` (paper Eq. 1-2): ``T_offset`` is a
    pure translation ``(0, y, 0)`` in the rig frame, so a positive ``y`` moves the camera to
    the left (rig y points left). ``T_sensor_rig: (4, 4)``, ``y_offsets_m: (K,)`` -> ``(K, 4, 4)``.

    Parameters
    ----------
    T_sensor_rig : (4, 4) float64
        The real camera mounting, sensor frame to rig frame (metres).
    y_offsets_m : (K,) float64, metres
        Lateral offsets along rig y (left positive).

    Returns
    -------
    (K, 4, 4) float64
        ``T_sensor'_rig`` of each shifted camera.

    >>> T = offset_T_sensor_rig(np.eye(4), np.array([0.0, 2.0]))
    >>> T[1, :3, 3].tolist()
    [0.0, 2.0, 0.0]
    """
    y = np.atleast_1d(np.asarray(y_offsets_m, dtype=np.float64))
    return perturb_T_sensor_rig(T_sensor_rig, lateral(y.ravel())).reshape(y.shape + (4, 4))


def T_sensor_world(T_rig_world: np.ndarray, T_sensor_rig: np.ndarray) -> np.ndarray:
    """Camera poses in the world, ``T_rig_world @ T_sensor_rig`` (broadcasting ``(..., 4, 4)``).

    The view is rendered with its inverse, ``T_world_sensor`` (docs/FORMATS.md §1).

    Parameters
    ----------
    T_rig_world : (..., 4, 4) float64
        Rig poses, rig frame to world frame (metres).
    T_sensor_rig : (..., 4, 4) float64
        Camera mountings, sensor frame to rig frame.

    Returns
    -------
    (..., 4, 4) float64
        Sensor frame to world frame.
    """
    return np.asarray(T_rig_world, dtype=np.float64) @ np.asarray(T_sensor_rig, dtype=np.float64)
