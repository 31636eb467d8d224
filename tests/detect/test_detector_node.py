"""The detector node (method ssim; mog2 for a static-camera method's restarts) in-process:
pairing by stamp, one BlobArray per frame, bad input."""

from __future__ import annotations

import itertools
import time

import cv2
import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from hostile_messages import (  # noqa: E402
    HOSTILE_PER_FRAME,
    Field,
    assert_unchanged_by_hostile_messages,
    hostile_stamp,
    record_publishes,
    spoil,
    unreadable_image,
)
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState  # noqa: E402

from tracker_detect.detector_node import DetectorNode  # noqa: E402
from tracker_msgs.msg import BlobArray, PtzState  # noqa: E402
from tracker_msgs_py.codec import array_to_image, camera_info, ns_to_stamp  # noqa: E402
from tracker_msgs_py.params import ParameterError  # noqa: E402

pytestmark = pytest.mark.ros

NS = 100_000_000
_namespaces = itertools.count()


@pytest.fixture(scope="module")
def context():
    """A context of our own, so other test modules' rclpy.init() cannot collide with ours."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


class Harness:
    """The detector plus a peer node that feeds it and records what it publishes."""

    def __init__(self, context, **params):
        self.namespace = f"/detect_test_{next(_namespaces)}"
        overrides = [Parameter("reliable_images", value=True)]
        overrides += [Parameter(k, value=v) for k, v in params.items()]
        self.node = DetectorNode(
            namespace=self.namespace, parameter_overrides=overrides, context=context
        )
        self.peer = rclpy.create_node("peer", namespace=self.namespace, context=context)
        self.images = self.peer.create_publisher(Image, "camera/image_raw", 50)
        self.compressed = self.peer.create_publisher(
            CompressedImage, "camera/image_raw/compressed", 50
        )
        self.states = self.peer.create_publisher(PtzState, "ptz/state", 50)
        self.joints = self.peer.create_publisher(JointState, "ptz/joint_states", 50)
        self.infos = self.peer.create_publisher(CameraInfo, "camera/camera_info", 50)
        self.detections: list[BlobArray] = []
        self.masks: list[Image] = []
        self.peer.create_subscription(BlobArray, "detections", self.detections.append, 50)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.peer)
        source = params.get("pose_source", "ptz_state")
        wanted = {"ptz_state": [self.states], "joint_states": [self.joints, self.infos]}
        compressed = params.get("image_transport") == "compressed"
        publishers = [self.compressed if compressed else self.images, *wanted.get(source, [])]
        assert self.spin_until(lambda: all(p.get_subscription_count() for p in publishers))

    def subscribe_mask(self):
        self.peer.create_subscription(Image, "detector/motion_mask", self.masks.append, 50)
        self.spin_until(lambda: self.node.mask_pub.get_subscription_count() > 0, 5.0)

    def spin_until(self, condition, timeout=5.0):
        deadline = time.monotonic() + timeout
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return condition()

    def settle(self, count):
        assert self.spin_until(lambda: len(self.detections) >= count), (
            f"{len(self.detections)} detections, {count} expected; counters {self.node.counters}, "
            f"{len(self.node.pending)} images waiting for a pose"
        )
        self.spin_until(lambda: len(self.detections) > count, 0.1)  # and nothing more arrives

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.peer.destroy_node()


@pytest.fixture
def harness_factory(context):
    made = []

    def make(**params):
        made.append(Harness(context, **params))
        return made[-1]

    yield make
    for h in made:
        h.close()


def scene_and_windows(n=8, w=120, h=90):
    """A static texture crossed by a square; the camera window pans right 5 px a frame."""
    rng = np.random.default_rng(0)
    noise = cv2.GaussianBlur(rng.standard_normal((200, 300)).astype(np.float32), (0, 0), 1.5)
    background = np.clip(128 + 60 * noise / noise.std(), 0, 255).astype(np.uint8)
    frames, windows = [], []
    for k in range(n):
        frame = background.copy()
        frame[80:96, 100 + 6 * k : 116 + 6 * k] = 30
        frames.append(frame)
        windows.append((40 + 5 * k, 50, w, h))
    return frames, windows


def image_msg(pixels, stamp_ns, encoding="mono8"):
    if encoding == "bgr8":
        pixels = cv2.cvtColor(pixels, cv2.COLOR_GRAY2BGR)
    return array_to_image(pixels, encoding, ns_to_stamp(stamp_ns), "ptz_camera_optical")


def state_msg(window, stamp_ns):
    msg = PtzState()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = "scene"
    msg.window.x, msg.window.y, msg.window.width, msg.window.height = (float(v) for v in window)
    msg.zoom = 1.0
    return msg


def test_one_blob_array_per_frame_with_poses_in_any_order(harness_factory):
    h = harness_factory(pose_source="ptz_state")
    frames, windows = scene_and_windows()
    for k, (frame, (x, y, w, hh)) in enumerate(zip(frames, windows, strict=True)):
        crop = frame[y : y + hh, x : x + w]
        if k % 2:  # the state before the image, or after it
            h.states.publish(state_msg(windows[k], k * NS))
            h.images.publish(image_msg(crop, k * NS, "bgr8"))
        else:
            h.images.publish(image_msg(crop, k * NS))
            h.spin_until(lambda: len(h.node.pending) == 1)
            h.states.publish(state_msg(windows[k], k * NS))
        h.settle(k + 1)  # a lockstep source waits for each answer
    assert len(h.detections) == len(frames)
    stamps = [d.header.stamp.sec * 10**9 + d.header.stamp.nanosec for d in h.detections]
    assert stamps == [k * NS for k in range(len(frames))]
    assert all(d.header.frame_id == "scene" for d in h.detections)
    assert all(not d.target_present and not d.blobs for d in h.detections[:3])
    for k, d in enumerate(h.detections[3:], start=3):
        assert d.target_present
        assert (d.ego_shift_x, d.ego_shift_y) == (15.0, 0.0)
        target = d.blobs[0]
        # scene coordinates: the square's current position lies in the largest blob
        assert target.bbox.x <= 100 + 6 * k and target.bbox.x + target.bbox.width >= 116 + 6 * k
        assert target.bbox.y <= 80 and target.bbox.y + target.bbox.height >= 96
        assert -1.0 <= target.score < 0.8  # mean SSIM over the dilated blob
    assert h.node.counters.frames == len(frames)


def test_compressed_images_give_the_blobs_the_same_raw_images_give(harness_factory):
    frames, windows = scene_and_windows()
    answers = {}
    for transport in ("raw", "compressed"):
        h = harness_factory(pose_source="ptz_state", image_transport=transport)
        for k, (frame, (x, y, w, hh)) in enumerate(zip(frames, windows, strict=True)):
            h.states.publish(state_msg(windows[k], k * NS))
            view = frame[y : y + hh, x : x + w]
            if transport == "raw":
                h.images.publish(image_msg(view, k * NS))
            else:  # png: lossless, so the detector sees the very same pixels
                png = cv2.imencode(".png", cv2.cvtColor(view, cv2.COLOR_GRAY2BGR))[1]
                msg = CompressedImage(format="png", data=png.tobytes())
                msg.header.stamp = ns_to_stamp(k * NS)
                h.compressed.publish(msg)
            h.settle(k + 1)
        answers[transport] = [blob_values(d) for d in h.detections]
    assert any(answers["raw"]) and answers["compressed"] == answers["raw"]
    h.compressed.publish(CompressedImage(format="jpeg", data=b"not an image"))
    h.spin_until(lambda: h.node.problems.count("undecodable compressed image") == 1)


def test_bad_encodings_repeated_stamps_and_a_new_epoch(harness_factory):
    h = harness_factory(pose_source="none", gap=1)
    frames, _ = scene_and_windows()
    h.images.publish(image_msg(frames[0][:90, :120], 0))
    h.settle(1)
    depth = Image(height=2, width=2, encoding="16UC1", step=4, data=bytes(8))
    depth.header.stamp = ns_to_stamp(1000 * NS)  # far ahead: refused, it moves no clock
    h.images.publish(depth)
    h.settle(2)
    assert h.node.counters.unsupported_encoding == 1
    assert not h.detections[1].target_present and not h.detections[1].blobs  # acknowledged
    h.images.publish(image_msg(frames[1][:90, :120], NS))  # the next frame, not a jump back
    h.settle(3)
    assert h.detections[2].compared_area > 0 and h.node.image_order.epochs == 0
    for stamp in (NS, 0):  # unreadable and not newer: not answered (it would move clocks back)
        old = Image(height=2, width=2, encoding="16UC1", step=4, data=bytes(8))
        old.header.stamp = ns_to_stamp(stamp)
        h.images.publish(old)
    h.spin_until(lambda: h.node.counters.unsupported_encoding == 3)
    h.images.publish(image_msg(frames[1][:90, :120], NS))  # repeated stamp: dropped
    h.spin_until(lambda: h.node.counters.stale_stamp >= 1)
    assert len(h.detections) == 3 and h.node.problems.count("repeat image stamp") == 1
    # Stamps going back are a restarted source: a new epoch, answered, with a fresh history.
    h.images.publish(image_msg(frames[2][:90, :120], NS // 2))
    h.images.publish(image_msg(frames[3][:90, :120], NS // 2 + NS))
    h.settle(5)
    assert [d.compared_area > 0 for d in h.detections[3:]] == [False, True]
    assert h.node.image_order.epochs == 1


def test_each_kind_of_malformed_image_gets_its_own_warning(harness_factory, capfd):
    h = harness_factory(pose_source="none")
    frames, _ = scene_and_windows()
    short = image_msg(frames[0][:90, :120], 0)
    short.data = bytes(short.data[:50])  # fewer bytes than step x height
    narrow = image_msg(frames[0][:90, :120], NS)
    narrow.step = 60  # shorter than a row
    again = image_msg(frames[0][:90, :120], 2 * NS)
    again.data = bytes(again.data[:10])
    for msg in (short, narrow, again):
        h.images.publish(msg)
    h.settle(3)  # each still answered with an empty BlobArray
    err = capfd.readouterr().err
    assert err.count("fewer bytes than step x height") == 1
    assert err.count("the step is shorter than a row") == 1
    assert h.node.problems.counts == {
        "image data shorter than step x height": 2,
        "image step shorter than a row": 1,
    }
    h.images.publish(image_msg(frames[1][:90, :120], 3 * NS))  # good images still work
    h.settle(4)


def test_size_change_resets_the_history(harness_factory):
    h = harness_factory(pose_source="none", gap=1)
    frames, _ = scene_and_windows()
    for k, size in enumerate([(90, 120), (90, 120), (80, 100), (80, 100)]):
        h.images.publish(image_msg(frames[k][: size[0], : size[1]], k * NS))
        h.settle(k + 1)
    assert h.node.counters.size_changes == 1
    assert [d.compared_area > 0 for d in h.detections] == [False, True, False, True]


def test_a_static_camera_method_restarts_when_the_view_moves(harness_factory):
    """mog2 through the node: detections in scene coordinates while the window stays, a model
    restart (counted, warned once, not a size change) for each frame whose window moved."""
    h = harness_factory(method="mog2", pose_source="ptz_state")
    frames, windows = scene_and_windows(n=10)
    for k, frame in enumerate(frames):
        x, y, w, hh = window = (40, 50, 120, 90) if k < 7 else windows[k]
        h.states.publish(state_msg(window, k * NS))
        h.images.publish(image_msg(frame[y : y + hh, x : x + w], k * NS, "bgr8"))
        h.settle(k + 1)
    compared = [d.compared_area > 0 for d in h.detections]
    assert compared == [False] * 5 + [True] * 2 + [False] * 3
    for k in (5, 6):
        # the square (its part MOG2 has not learned yet), dilated by the radius-4 diamond
        [blob] = h.detections[k].blobs
        x0, y0 = 100 + 6 * k, 80  # scene px
        assert x0 <= blob.centroid_x <= x0 + 16 and y0 <= blob.centroid_y <= y0 + 16
        assert x0 - 4 <= blob.bbox.x and blob.bbox.x + blob.bbox.width <= x0 + 20
        assert y0 - 4 <= blob.bbox.y and blob.bbox.y + blob.bbox.height <= y0 + 20
    assert not any(d.blobs for d in h.detections[7:])
    assert (h.node.counters.view_restarts, h.node.counters.size_changes) == (3, 0)
    assert h.node.problems.count("detector restarted: the view moved") == 3


def test_debug_images_only_while_subscribed(harness_factory):
    h = harness_factory(pose_source="none", gap=1)
    frames, _ = scene_and_windows()
    for k in range(2):
        h.images.publish(image_msg(frames[k][:90, :120], k * NS))
        h.settle(k + 1)
    h.subscribe_mask()
    assert h.masks == []
    h.images.publish(image_msg(frames[2][:90, :120], 2 * NS))
    h.settle(3)
    assert h.spin_until(lambda: len(h.masks) == 1)
    mask = h.masks[0]
    assert (mask.encoding, mask.width, mask.height) == ("mono8", 120, 90)
    assert mask.header.frame_id == "ptz_camera_optical"
    assert set(np.frombuffer(bytes(mask.data), np.uint8)) == {0, 255}


def test_joint_states_and_camera_info_give_the_shift(harness_factory):
    """A real pan-tilt unit: the window shift comes from the pan angle and the focal length."""
    fx = 200.0
    h = harness_factory(pose_source="joint_states", scene_focal_length=fx, gap=1)
    frames, windows = scene_and_windows(n=3)
    info = camera_info(120, 90, fx, fx, 60.0, 45.0, ns_to_stamp(0), "ptz_camera_optical")
    h.infos.publish(info)
    h.spin_until(lambda: h.node.camera is not None)
    for k, (x, y, w, hh) in enumerate(windows):
        joints = JointState(name=["tilt_joint", "pan_joint"], position=[0.0, -0.025 * k])
        joints.header.stamp = ns_to_stamp(k * NS)
        h.joints.publish(joints)
        h.images.publish(image_msg(frames[k][y : y + hh, x : x + w], k * NS))
        h.settle(k + 1)
    # pan decreasing by 0.025 rad moves the view right by 200 * 0.025 = 5 scene px
    assert h.detections[1].ego_shift_x == pytest.approx(5.0, abs=1e-6)
    assert h.detections[2].ego_shift_y == pytest.approx(0.0, abs=1e-9)
    assert h.detections[2].target_present


def test_images_without_a_pose_are_answered_empty(harness_factory):
    h = harness_factory(pose_source="ptz_state", gap=1)
    frames, windows = scene_and_windows(n=3)
    x, y, w, hh = windows[0]
    h.images.publish(image_msg(frames[0][y : y + hh, x : x + w], 0))
    h.states.publish(state_msg(windows[1], NS))  # the pose for stamp 0 never comes
    h.settle(1)
    assert h.node.counters.without_pose == 1
    assert not h.detections[0].target_present


def test_parameters_are_validated_on_change(harness_factory):
    h = harness_factory(pose_source="none")
    node = h.node

    def set_param(name, value):
        return node.set_parameters([Parameter(name, value=value)])[0]

    assert not set_param("threshold", 1.5).successful
    assert not set_param("kernel_size", 4).successful
    assert not set_param("morphology", ["fill", "blur"]).successful
    assert not set_param("compensation", "guess").successful
    assert not set_param("pose_source", "joint_states").successful  # read-only
    assert node.detector.config.threshold == 0.5
    result = set_param("threshold", 0.6)
    assert result.successful
    assert node.detector.config.threshold == 0.6
    assert set_param("compensation", "phase_correlation").successful
    assert node.detector.config.compensation == "phase_correlation"


def test_estimate_needs_an_estimator(context):
    with pytest.raises(ParameterError, match="estimate"):
        DetectorNode(
            context=context,
            namespace="/detect_test_bad",
            parameter_overrides=[
                Parameter("pose_source", value="estimate"),
                Parameter("compensation", value="known"),
            ],
        )


def test_a_bad_pose_is_one_warning_an_empty_answer_and_changes_nothing(harness_factory, capfd):
    """Extra frames between good ones whose pose has a window far off the scene either way, or
    one 1e5 px wide (the background mosaic would need TiB), or a NaN focal length: one warning
    per kind, an empty answer for the windows, the node lives, and the good frames' detections
    are the clean run's (the background detector, which person_motion runs too)."""
    frames, windows = scene_and_windows()
    bad_windows = [(1e6, 1e6, 120, 90), (-1e5, -1e5, 120, 90), (0, 0, 1e5, 1e5 * 0.75)]

    def run(with_bad: bool) -> list[list[tuple[float, ...]]]:
        h = harness_factory(pose_source="ptz_state", method="ssim_background")
        answers = []
        for k, (frame, (x, y, w, hh)) in enumerate(zip(frames, windows, strict=True)):
            if with_bad and 3 <= k < 3 + len(bad_windows):
                stamp = k * NS - NS // 2
                h.states.publish(state_msg(bad_windows[k - 3], stamp))
                h.images.publish(image_msg(frame[y : y + hh, x : x + w], stamp))
                h.spin_until(lambda: len(h.detections) > len(answers))
                assert not h.detections.pop().blobs
            if with_bad and k == 3 + len(bad_windows):  # a lone pose, of the next good image
                nan_focal = state_msg(windows[k], k * NS)
                nan_focal.focal_length = float("nan")
                h.states.publish(nan_focal)
            h.states.publish(state_msg(windows[k], k * NS))
            h.images.publish(image_msg(frame[y : y + hh, x : x + w], k * NS))
            wanted = k * NS
            h.spin_until(lambda w=wanted: any(_stamp(d) == w for d in h.detections))
            good = next(d for d in h.detections if _stamp(d) == wanted)
            answers.append(
                [(b.centroid_x, b.centroid_y, b.bbox.width, b.bbox.height) for b in good.blobs]
            )
        return answers

    clean = run(False)
    capfd.readouterr()
    assert run(True) == clean and any(clean)
    err = capfd.readouterr().err
    assert err.count("would grow the background") == 1
    assert err.count("focal_length nan") == 1


def test_the_seed_method_answers_far_off_and_huge_views_and_keeps_detecting(harness_factory):
    """Seed 000's k-3 SSIM holds no background, so a view far off or 1e5 px wide is a view like any
    other (it enters the k-3 history as every frame does): each is answered without comparing
    (nothing overlaps), no value is non-finite, and the good frames three later detect again."""
    frames, windows = scene_and_windows(n=12)
    bad_windows = [(1e6, 1e6, 120, 90), (-1e5, -1e5, 120, 90), (0, 0, 1e5, 1e5 * 0.75)]
    h = harness_factory(pose_source="ptz_state", method="ssim")
    for k, (frame, (x, y, w, hh)) in enumerate(zip(frames, windows, strict=True)):
        window = bad_windows[k - 4] if 4 <= k < 4 + len(bad_windows) else (x, y, w, hh)
        h.states.publish(state_msg(window, k * NS))
        h.images.publish(image_msg(frame[y : y + hh, x : x + w], k * NS))
        h.settle(k + 1)
        blobs = h.detections[-1].blobs
        assert all(np.isfinite([b.centroid_x, b.centroid_y, b.area]).all() for b in blobs)
        if 4 <= k < 4 + len(bad_windows):
            assert not blobs
    assert h.detections[-1].blobs  # the k-3 history holds good views again


def _stamp(msg: BlobArray) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


WINDOW_STATE_FIELDS = [
    Field("window.x"),
    Field("window.y"),
    Field("window.width", positive=True),
    Field("window.height", positive=True),
    Field("focal_length", positive=True),
]


def feed(h, topic, publisher, msg):
    handled = h.node.messages_handled(topic)
    publisher.publish(msg)
    assert h.spin_until(lambda: h.node.messages_handled(topic) > handled)


JOINT_FIELDS = [Field("position[0]"), Field("position[1]")]
INFO_FIELDS = [
    Field("k[0]", positive=True),
    Field("k[4]", positive=True),
    Field("k[2]"),
    Field("k[5]"),
]
FX = 200.0  # px/rad of the joint-state camera: its pan moves the window 5 px a frame


def pan_tilt_joints(stamp_ns, k):
    joints = JointState(name=["tilt_joint", "pan_joint"], position=[0.0, -0.025 * k])
    joints.header.stamp = ns_to_stamp(stamp_ns)
    return joints


def intrinsics(stamp_ns, _k=0):
    return camera_info(120, 90, FX, FX, 60.0, 45.0, ns_to_stamp(stamp_ns), "ptz_camera_optical")


class PoseFeed:
    """The good pose messages of frame k for one pose source, and hostile ones."""

    def __init__(self, h, pose_source, windows):
        self.h, self.windows = h, windows
        self.joint_states = pose_source == "joint_states"
        if self.joint_states:
            feed(h, "camera/camera_info", h.infos, intrinsics(0))

    def good(self, k, stamp):
        if self.joint_states:
            feed(self.h, "ptz/joint_states", self.h.joints, pan_tilt_joints(stamp, k))
        else:
            feed(self.h, "ptz/state", self.h.states, state_msg(self.windows[k], stamp))

    def hostile(self, rng, k, stamp):
        if not self.joint_states:
            msg, _ = spoil(rng, state_msg(self.windows[k], stamp), WINDOW_STATE_FIELDS, stamp, NS)
            feed(self.h, "ptz/state", self.h.states, msg)
        elif rng.integers(2):
            msg, _ = spoil(rng, pan_tilt_joints(stamp, k), JOINT_FIELDS, stamp, NS)
            feed(self.h, "ptz/joint_states", self.h.joints, msg)
        else:
            msg, _ = spoil(rng, intrinsics(stamp), INFO_FIELDS, stamp, NS)
            feed(self.h, "camera/camera_info", self.h.infos, msg)


@pytest.mark.parametrize(
    ("method", "pose_source"),
    [
        ("ssim_background", "ptz_state"),
        ("person_motion", "ptz_state"),
        ("ssim_background", "joint_states"),
    ],
)
def test_hundreds_of_hostile_messages_change_no_good_answer(
    harness_factory, capfd, method, pose_source
):
    """Seeded: 20 frames of a panning camera (the background detector, and the person model fed
    by it), and after each 15 hostile poses (a PtzState's window field or focal length; a joint
    position; a CameraInfo's fx, fy, cx or cy: non-finite, huge or negative) or unreadable images,
    stamped between frames, far ahead, back in time, on the last frame, the next frame's or before
    zero. The good frames' detections are the clean run's, the node lives, and each cause is
    logged once."""
    rng = np.random.default_rng(67)
    frames, windows = scene_and_windows(n=20)
    extra = {"scene_focal_length": FX} if pose_source == "joint_states" else {}

    def run(hostile: bool):
        h = harness_factory(pose_source=pose_source, method=method, **extra)
        poses = PoseFeed(h, pose_source, windows)
        published = record_publishes(h.node.detections_pub)
        answers = []
        for k, (frame, (x, y, w, hh)) in enumerate(zip(frames, windows, strict=True)):
            stamp = k * NS
            image = image_msg(frame[y : y + hh, x : x + w], stamp)
            poses.good(k, stamp)
            before = len(published)  # an unreadable image may have been answered at this stamp
            feed(h, "camera/image_raw", h.images, image)
            assert h.spin_until(
                lambda s=stamp, b=before: any(_stamp(d) == s for d in published[b:])
            )
            good = next(d for d in published[before:] if _stamp(d) == stamp)
            answers.append((blob_values(good), good.compared_area, good.ego_shift_x))
            for _ in range(HOSTILE_PER_FRAME if hostile else 0):
                if rng.integers(2):
                    poses.hostile(rng, k, stamp)
                else:
                    bad = unreadable_image(rng, image, hostile_stamp(rng, stamp, NS))
                    feed(h, "camera/image_raw", h.images, bad)
        return answers, dict(h.node.problems.counts)

    clean = assert_unchanged_by_hostile_messages(run, capfd, counted_at_least=250)
    assert any(blobs for blobs, _, _ in clean)


def blob_values(msg):
    return [(b.centroid_x, b.centroid_y, b.bbox.width, b.bbox.height, b.area) for b in msg.blobs]


def test_a_vision_msgs_consumer_gets_every_frames_detections(harness_factory):
    from vision_msgs.msg import Detection2DArray

    from tracker_msgs_py.codec import result_qos

    h = harness_factory(pose_source="ptz_state", method="ssim_background")
    vision = []
    h.peer.create_subscription(Detection2DArray, "detections_2d", vision.append, result_qos())
    assert h.spin_until(lambda: h.node.vision_pub.get_subscription_count() == 1)
    frames, windows = scene_and_windows()
    for k, (frame, (x, y, w, hh)) in enumerate(zip(frames, windows, strict=True)):
        h.states.publish(state_msg(windows[k], k * NS))
        h.images.publish(image_msg(frame[y : y + hh, x : x + w], k * NS))
        h.settle(k + 1)
    assert h.spin_until(lambda: len(vision) == len(h.detections))
    for suite, converted in zip(h.detections, vision, strict=True):
        assert converted.header == suite.header
        assert len(converted.detections) == len(suite.blobs)
        for blob, detection in zip(suite.blobs, converted.detections, strict=True):
            assert detection.results[0].hypothesis.class_id == blob.label
            assert detection.results[0].pose.pose.position.x == blob.centroid_x
    assert any(converted.detections for converted in vision)
