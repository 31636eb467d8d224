"""JointPoseBridge: a real unit's JointState + CameraInfo as one pan-tilt pose per image."""

from __future__ import annotations

import math

import pytest

from tracker_detect.registration import CameraIntrinsics
from tracker_ptz_sim.control.joint_pose import JointPoseBridge, JointSample, SceneSettings

MS = 1_000_000
CAMERA = CameraIntrinsics(640, 480, 500.0, 500.0, 320.0, 240.0)


def bridge(**scene) -> JointPoseBridge:
    return JointPoseBridge(SceneSettings(**scene), max_gap_ns=200 * MS, max_age_ns=300 * MS)


def test_an_image_waits_for_the_joint_state_after_it_and_gets_the_interpolated_pose():
    pose_of = bridge(width=2000, height=1000)
    assert pose_of.add_joints(JointSample(0, pan=0.0, tilt=0.0)) == []
    assert pose_of.add_camera_info(50 * MS, CAMERA) == []  # no joint state at or after it yet
    (pose,) = pose_of.add_joints(JointSample(100 * MS, pan=0.2, tilt=-0.1))
    assert pose.stamp_ns == 50 * MS
    assert pose.pan == pytest.approx(0.1) and pose.tilt == pytest.approx(-0.05)
    # rates by differentiating the positions (the driver gave no velocities)
    assert pose.pan_rate == pytest.approx(1.0) and pose.tilt_rate == pytest.approx(-0.5)
    assert pose.moving
    # scene px = camera px at zoom 1: f = fx, and the view centre is cx - f * pan
    assert pose.focal_length == 500.0 and pose.zoom == pytest.approx(1.0)
    center_x = pose.window.x + pose.window.width / 2
    center_y = pose.window.y + pose.window.height / 2
    assert center_x == pytest.approx(1000 - 500 * 0.1, abs=1.0)
    assert center_y == pytest.approx(500 + 500 * -0.05, abs=1.0)
    # the window spans the camera's field of view: 2 atan(320 / 500) rad of scene
    assert pose.window.width == pytest.approx(500 * 2 * math.atan(320 / 500), rel=1e-3)


def test_the_zoom_joint_is_reported_and_a_zoomed_camera_sees_a_smaller_window():
    pose_of = bridge(width=2000, height=1000, focal_length=500.0)
    zoomed = CameraIntrinsics(640, 480, 1000.0, 1000.0, 320.0, 240.0)  # K follows the zoom
    pose_of.add_joints(JointSample(0, 0.0, 0.0, zoom=2.0, pan_rate=0.0, tilt_rate=0.0))
    (pose,) = pose_of.add_camera_info(0, zoomed)
    assert pose.zoom == 2.0 and not pose.moving
    assert pose.window.width == pytest.approx(500 * 2 * math.atan(320 / 1000), rel=1e-3)


def test_without_a_zoom_joint_the_zoom_is_the_focal_length_ratio():
    pose_of = bridge()
    pose_of.add_joints(JointSample(0, 0.0, 0.0))
    pose_of.add_joints(JointSample(10 * MS, 0.0, 0.0))
    pose_of.add_camera_info(0, CAMERA)  # fixes f = 500
    (pose,) = pose_of.add_camera_info(10 * MS, CameraIntrinsics(640, 480, 750.0, 750.0, 320, 240))
    assert pose.zoom == pytest.approx(1.5)


def test_give_up_uses_the_latest_earlier_joint_state_if_recent_enough_else_drops():
    pose_of = bridge()
    pose_of.add_joints(JointSample(0, 0.3, 0.0, pan_rate=0.0, tilt_rate=0.0))
    pose_of.add_camera_info(200 * MS, CAMERA)
    pose_of.add_camera_info(400 * MS, CAMERA)
    released = pose_of.give_up()
    assert [p.stamp_ns for p in released] == [200 * MS]  # 400 ms is past max_age
    assert released[0].pan == 0.3
    assert pose_of.dropped == [(400 * MS, "no JointState near the image's stamp")]
    assert not pose_of.waiting


def test_every_camera_info_is_released_once_even_without_any_joint_state():
    pose_of = bridge()
    pose_of.add_camera_info(0, CAMERA)
    assert pose_of.give_up() == []
    assert pose_of.dropped == [(0, "no JointState received yet")]
    assert not pose_of.waiting


def test_a_joint_stream_that_jumps_back_starts_a_new_epoch():
    pose_of = bridge()
    pose_of.add_joints(JointSample(5_000 * MS, 0.5, 0.0, pan_rate=0.0, tilt_rate=0.0))
    pose_of.add_joints(JointSample(0, -0.2, 0.0, pan_rate=0.0, tilt_rate=0.0))  # replay restarted
    (pose,) = pose_of.add_camera_info(0, CAMERA)
    assert pose.pan == -0.2


def test_a_unit_reporting_at_1_hz_is_carried_forward_by_the_commanded_rates():
    """An Axis-like unit: joint states once a second, velocities 0, while it pans at the commanded
    rate (reaching it with a 0.1 s lag). Each 10 Hz image released on the latest joint state."""
    from tracker_ptz_sim.control.unit_joints import CommandedMotion

    def run(motion):
        pose_of = JointPoseBridge(max_gap_ns=1500 * MS, max_age_ns=1500 * MS, motion=motion)
        pan, rate, errors = 0.0, 0.0, []
        for k in range(60):  # 6 s at 10 fps
            stamp = k * 100 * MS
            commanded = 0.4 if (k // 20) % 2 == 0 else -0.3  # turn, turn back, turn again
            if motion is not None:
                motion.add(stamp, commanded, 0.0)
            rate += (commanded - rate) * 0.5  # the unit's own lag
            pan += rate * 0.1
            if k % 10 == 0:
                pose_of.add_joints(JointSample(stamp, pan, 0.0, pan_rate=0.0, tilt_rate=0.0))
            (pose,) = pose_of.add_camera_info(stamp, CAMERA) or pose_of.give_up()
            errors.append(abs(pose.pan - pan))
        return sum(errors) / len(errors)

    held, carried = run(None), run(CommandedMotion())
    # mean error 0.153 rad held (up to 0.9 s of turning behind), 0.012 rad carried forward
    assert held > 0.1
    assert carried < 0.1 * held, (held, carried)
