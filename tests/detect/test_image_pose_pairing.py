"""Images wait for the pose of their stamp and are released once each, in arrival order."""

from __future__ import annotations

import numpy as np

from tracker_detect.image_pose_pairing import ImagePosePairing, SceneSettings
from tracker_detect.pose_buffer import PoseStatus
from tracker_detect.registration import CameraIntrinsics

IMAGE = np.zeros((60, 80, 3), np.uint8)


def released(items):
    return [(p.token, p.status) for p in items]


def test_an_image_waits_for_its_window_and_gets_its_view():
    pairing = ImagePosePairing("ptz_state", capacity=4)
    assert pairing.add_image("a", 100, IMAGE) == []
    [paired] = pairing.add_pose(100, (10.0, 20.0, 160.0, 120.0, 300.0))
    assert paired.token == "a" and paired.found
    assert paired.view.to_scene(0, 0) == (10.0, 20.0) and paired.view.scale_x == 2.0


def test_images_without_a_pose_are_released_in_order_and_never_dropped():
    pairing = ImagePosePairing("ptz_state", capacity=2)
    pairing.add_pose(200, (0.0, 0.0, 80.0, 60.0, 300.0))
    assert released(pairing.add_image("old", 100, IMAGE)) == [("old", PoseStatus.MISSING)]
    assert pairing.add_image("b", 300, IMAGE) == [] and pairing.add_image("c", 400, IMAGE) == []
    assert released(pairing.add_image("d", 500, IMAGE)) == [("b", PoseStatus.WAIT)]  # overflow
    assert released(pairing.new_epoch(50)) == [("c", PoseStatus.MISSING), ("d", PoseStatus.MISSING)]


def test_joint_states_wait_for_the_camera_info_then_use_it():
    pairing = ImagePosePairing("joint_states", capacity=4, scene=SceneSettings(800, 600, 0.0))
    pairing.add_pose(100, (0.0, 0.0))
    assert pairing.add_image("a", 100, IMAGE) == [] and pairing.waiting_for_camera_info
    [paired] = pairing.set_camera(CameraIntrinsics(80, 60, 100.0, 100.0, 40.0, 30.0))
    assert paired.found and not pairing.waiting_for_camera_info
    cx, cy = paired.view.to_scene(40.0, 30.0)  # the optical centre looks at the scene centre
    assert abs(cx - 400.0) < 1e-6 and abs(cy - 300.0) < 1e-6


def test_static_and_estimated_poses_need_no_pose_messages():
    [static] = ImagePosePairing("none").add_image("s", 1, IMAGE)
    [estimated] = ImagePosePairing("estimate").add_image("e", 1, IMAGE)
    assert static.found and static.view.width == 80
    assert estimated.found and estimated.view is None
