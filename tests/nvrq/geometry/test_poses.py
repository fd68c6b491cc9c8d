"""Poses against SciPy's Rotation/Slerp, and the novel-view offset of paper Eq. 1-2."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from nvrq.geometry.poses import (
    T_sensor_world,
    interpolate_poses,
    invert_rigid,
    matrix_to_pose7,
    offset_T_sensor_rig,
    pose7_to_matrix,
    quat_to_rotmat,
    rotmat_to_quat,
)

rng = np.random.default_rng(7)


def test_quaternion_matrix_match_scipy():
    q = Rotation.random(500, random_state=1).as_quat()  # scipy: [x, y, z, w] like docs/FORMATS.md §1
    np.testing.assert_allclose(quat_to_rotmat(q), Rotation.from_quat(q).as_matrix(), atol=1e-12)
    back = rotmat_to_quat(Rotation.from_quat(q).as_matrix())
    # same rotation (q and -q are equal): |<q, back>| = 1
    np.testing.assert_allclose(np.abs(np.sum(back * q, axis=1)), 1.0, atol=1e-12)


def test_pose7_round_trip_and_inverse():
    poses = np.concatenate(
        [rng.normal(size=(50, 3)) * 10, Rotation.random(50, random_state=2).as_quat()], 1
    )
    T = pose7_to_matrix(poses)
    np.testing.assert_allclose(pose7_to_matrix(matrix_to_pose7(T)), T, atol=1e-12)
    np.testing.assert_allclose(invert_rigid(T) @ T, np.broadcast_to(np.eye(4), T.shape), atol=1e-12)
    np.testing.assert_allclose(invert_rigid(T), np.linalg.inv(T), atol=1e-10)


def test_interpolation_matches_scipy_slerp_and_never_extrapolates():
    ts = np.array([0, 100_000, 250_000, 400_000])
    rots = Rotation.random(4, random_state=3)
    trans = rng.normal(size=(4, 3))
    T = np.zeros((4, 4, 4))
    T[:, :3, :3] = rots.as_matrix()
    T[:, :3, 3] = trans
    T[:, 3, 3] = 1
    q = np.array([-1, 0, 50_000, 100_000, 333_333, 400_000, 400_001])
    Tq, ok = interpolate_poses(ts, T, q)
    assert ok.tolist() == [False, True, True, True, True, True, False]
    inside = q[ok]
    ref_R = Slerp(ts, rots)(inside).as_matrix()
    np.testing.assert_allclose(Tq[ok, :3, :3], ref_R, atol=1e-10)
    ref_t = np.stack([np.interp(inside, ts, trans[:, j]) for j in range(3)], 1)
    np.testing.assert_allclose(Tq[ok, :3, 3], ref_t, atol=1e-12)
    # exact samples reproduce the stored pose bit for bit
    assert np.array_equal(Tq[1], T[0]) and np.array_equal(Tq[5], T[3])


def test_zero_offset_reproduces_gt_pose_exactly():
    T_sensor_rig = pose7_to_matrix(
        np.array([1.6, 0.1, 1.4, *Rotation.random(random_state=4).as_quat()])
    )
    assert np.array_equal(offset_T_sensor_rig(T_sensor_rig, np.array([0.0]))[0], T_sensor_rig)


@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, 137.0, -60.0])
def test_positive_offset_moves_camera_left_in_world(yaw_deg):
    """Hand-worked: a rig yawed by psi has its left direction (-sin psi, cos psi, 0) in the world.

    A +2 m offset must move the camera centre by exactly 2 m along that direction.
    """
    psi = np.radians(yaw_deg)
    T_rig_world = pose7_to_matrix(
        np.array([100.0, -20.0, 0.3, 0, 0, np.sin(psi / 2), np.cos(psi / 2)])
    )
    # camera x right, y down, z forward mounted 1.5 m up, 1.2 m forward
    T_sensor_rig = np.array([[0, 0, 1, 1.2], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1.0]])
    T_off = offset_T_sensor_rig(T_sensor_rig, np.array([0.0, 2.0, -1.0]))
    centres = T_sensor_world(T_rig_world, T_off)[:, :3, 3]
    left = np.array([-np.sin(psi), np.cos(psi), 0.0])
    np.testing.assert_allclose(centres[1] - centres[0], 2.0 * left, atol=1e-12)
    np.testing.assert_allclose(centres[2] - centres[0], -1.0 * left, atol=1e-12)
    # the orientation is unchanged by a pure translation offset
    np.testing.assert_array_equal(T_off[1, :3, :3], T_sensor_rig[:3, :3])
    # and the camera's own -x axis (its left) is the rig's left
    cam_left_world = T_sensor_world(T_rig_world, T_sensor_rig)[:3, :3] @ np.array([-1.0, 0, 0])
    np.testing.assert_allclose(cam_left_world, left, atol=1e-12)
