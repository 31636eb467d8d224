"""The unit's TF tree: the URDF's frames and axes, and a TF listener (a buffer of /tf and
/tf_static, composed here: tf2_ros has no wheel) that resolves the camera's optical frame in its
base at the simulated camera's joint angles, within 1e-6 rad, and follows it as it pans."""

from __future__ import annotations

import math
import time
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

from tracker_ptz_sim.control.pan_tilt_frames import (
    PanTiltFrames,
    Transform,
    compose,
    rotate,
    view_direction,
)


def chain(frames, transforms):
    """`frames.optical` in `frames.base`, through the transforms by child."""
    by_child = {t.child: t for t in transforms}
    path, frame = [], frames.optical
    while frame != frames.base:
        path.append(by_child[frame])
        frame = by_child[frame].parent
    result = path.pop()
    while path:
        result = compose(result, path.pop())
    return result


@pytest.mark.parametrize(("pan", "tilt"), [(0.0, 0.0), (0.4, 0.0), (-0.7, 0.3), (1.2, -0.25)])
def test_the_optical_axis_looks_where_pan_and_tilt_say(pan, tilt):
    frames = PanTiltFrames()
    optical = chain(frames, frames.moving(pan, tilt) + frames.fixed())
    assert optical == frames.optical_in_base(pan, tilt)
    forward = rotate(optical.rotation, (0.0, 0.0, 1.0))  # optical z: the view
    np.testing.assert_allclose(forward, view_direction(pan, tilt), atol=1e-12)
    right = rotate(optical.rotation, (1.0, 0.0, 0.0))  # optical x: the image's right
    np.testing.assert_allclose(right, (math.sin(pan), -math.cos(pan), 0.0), atol=1e-12)
    # a point right of and below the centre by pan / tilt offsets: a ray into the image's
    # lower right, the view at those joint angles
    ray = frames.ray(pan, tilt, 0.1, 0.05)
    assert ray[0] > 0 and ray[1] > 0 and ray[2] > 0
    np.testing.assert_allclose(
        rotate(optical.rotation, ray), view_direction(pan - 0.1, tilt + 0.05), atol=1e-12
    )


def test_the_urdf_names_the_joints_and_frames_under_the_prefix():
    robot = ElementTree.fromstring(PanTiltFrames("cam1/").urdf())
    joints = {j.get("name"): j for j in robot.iter("joint")}
    assert joints["cam1/pan_joint"].find("axis").get("xyz") == "0 0 1"
    assert joints["cam1/tilt_joint"].find("axis").get("xyz") == "0 1 0"
    links = {link.get("name") for link in robot.iter("link")}
    assert {"cam1/ptz_base", "cam1/ptz_camera_optical"} <= links
    parents = {j.find("child").get("link"): j.find("parent").get("link") for j in joints.values()}
    assert parents["cam1/ptz_camera_optical"] == "cam1/ptz_camera_link"


def test_a_tf_listener_follows_the_simulated_camera_as_it_pans():
    rclpy = pytest.importorskip("rclpy")
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import Image, JointState
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage

    from tracker_msgs.msg import PtzCommand
    from tracker_msgs_py.codec import array_to_image, command_qos, image_qos, ns_to_stamp
    from tracker_ptz_sim.control.ptz_tf_node import LATCHED, TF_QOS, PtzTfNode
    from tracker_ptz_sim.simulation.ptz_camera_node import PtzCameraNode

    context = rclpy.Context()
    rclpy.init(context=context)
    camera = PtzCameraNode(context=context, parameter_overrides=[])
    tf_node = PtzTfNode(context=context)
    peer = rclpy.create_node("tf_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    for node in (camera, tf_node, peer):
        executor.add_node(node)
    buffer: dict[str, Transform] = {}
    joints: list[JointState] = []
    descriptions: list[String] = []

    def take(msg):
        for t in msg.transforms:
            q, v = t.transform.rotation, t.transform.translation
            buffer[t.child_frame_id] = Transform(
                t.header.frame_id, t.child_frame_id, (v.x, v.y, v.z), (q.x, q.y, q.z, q.w)
            )

    peer.create_subscription(TFMessage, "/tf", take, TF_QOS)
    peer.create_subscription(TFMessage, "/tf_static", take, LATCHED)
    peer.create_subscription(String, "robot_description", descriptions.append, LATCHED)
    peer.create_subscription(JointState, "ptz/joint_states", joints.append, 50)
    scenes = peer.create_publisher(Image, "scene/image_raw", image_qos(False))
    commands = peer.create_publisher(PtzCommand, "ptz/command", command_qos())

    def spin_until(condition, timeout=5.0):
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, "timed out"
            executor.spin_once(timeout_sec=0.02)

    try:
        spin_until(lambda: scenes.get_subscription_count() and commands.get_subscription_count())
        pixels = np.random.default_rng(0).integers(0, 255, (480, 1200, 3), np.uint8)
        frames = PanTiltFrames()
        looked = []
        for k in range(12):
            if k == 2:
                command = PtzCommand(mode=PtzCommand.MODE_VELOCITY, pan_rate=0.4, tilt_rate=0.1)
                command.header.stamp = ns_to_stamp((k - 1) * 100_000_000)
                commands.publish(command)
                spin_until(lambda: camera.commands_received == 1)
            count = len(joints)
            scenes.publish(array_to_image(pixels, "bgr8", ns_to_stamp(k * 100_000_000), "scene"))
            spin_until(lambda c=count: len(joints) > c)
            pan, tilt = joints[-1].position[:2]
            spin_until(
                lambda p=pan: "ptz_pan_link" in buffer and _pan_of(buffer) == pytest.approx(p)
            )
            spin_until(lambda: frames.optical in buffer)
            optical = chain(frames, list(buffer.values()))
            forward = rotate(optical.rotation, (0.0, 0.0, 1.0))
            error = math.acos(min(1.0, float(np.dot(forward, view_direction(pan, tilt)))))
            assert error < 1e-6, (k, pan, tilt, error)
            looked.append((pan, tilt))
        assert looked[-1][0] > looked[0][0] + 0.1  # it panned left, and the tree followed
        spin_until(lambda: descriptions)  # latched: delivered once the reader has matched
        assert '<link name="ptz_camera_optical"/>' in descriptions[0].data
    finally:
        executor.shutdown()
        for node in (camera, tf_node, peer):
            node.destroy_node()
        rclpy.shutdown(context=context)


def _pan_of(buffer):
    q = buffer["ptz_pan_link"].rotation
    return 2 * math.atan2(q[2], q[3])
