"""vision_msgs and tf2_msgs: the workspace's stand-ins carry the installed packages' types (same
type hashes), and the detector's and tracker's results reach a consumer that knows only
vision_msgs: every frame, with the suite's class ids, scores and tracking ids."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")

from ament_index_python.packages import get_package_share_directory  # noqa: E402
from node_harness import NodeHarness  # noqa: E402
from vision_msgs.msg import Detection2DArray  # noqa: E402

from tracker_filter.tracker_node import TrackerNode  # noqa: E402
from tracker_msgs.msg import Blob, BlobArray, Track, TrackArray  # noqa: E402
from tracker_msgs_py.codec import ns_to_stamp, result_qos  # noqa: E402
from tracker_msgs_py.vision import detections_to_vision, tracks_to_vision  # noqa: E402

pytestmark = pytest.mark.ros
NS = 100_000_000

# `ros2 topic info -v /tf` on ROS 2 Jazzy (the hash every Jazzy tf2_msgs has).
JAZZY_TF_MESSAGE = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
# From this workspace's definitions, field for field vision_msgs 4.1.1's (Jazzy); no published
# value was found to compare with, so this guards the definitions against edits.
VISION_DETECTION_2D_ARRAY = (
    "RIHS01_214274120007f4a683866481336b70310268cfa107aebe9d594a6acf75bda968"
)


def type_hash(package: str, message: str) -> str:
    path = Path(get_package_share_directory(package)) / "msg" / f"{message}.json"
    hashes = json.loads(path.read_text())["type_hashes"]
    return next(h["hash_string"] for h in hashes if h["type_name"] == f"{package}/msg/{message}")


def test_the_stand_ins_have_the_installed_packages_type_hashes():
    assert type_hash("tf2_msgs", "TFMessage") == JAZZY_TF_MESSAGE
    assert type_hash("vision_msgs", "Detection2DArray") == VISION_DETECTION_2D_ARRAY


def blob(x, y, label="person", score=0.8, angle=0.0):
    b = Blob(centroid_x=x, centroid_y=y, area=400, label=label, score=score, angle=angle)
    b.bbox.x, b.bbox.y, b.bbox.width, b.bbox.height = x - 10.0, y - 30.0, 20.0, 60.0
    return b


def test_a_blob_array_becomes_one_detection_per_blob_with_its_class_and_score():
    msg = BlobArray(blobs=[blob(100.0, 150.0), blob(300.0, 80.0, label="", score=0.3, angle=0.5)])
    msg.header.stamp, msg.header.frame_id = ns_to_stamp(7 * NS), "scene"
    vision = detections_to_vision(msg)
    assert vision.header == msg.header and len(vision.detections) == 2
    first, second = vision.detections
    assert (first.bbox.center.position.x, first.bbox.center.position.y) == (100.0, 150.0)
    assert (first.bbox.size_x, first.bbox.size_y) == (20.0, 60.0) and first.id == ""
    assert first.results[0].hypothesis.class_id == "person"
    assert first.results[0].hypothesis.score == 0.8
    assert first.results[0].pose.pose.position.x == 100.0
    assert second.results[0].hypothesis.class_id == "motion" and second.bbox.center.theta == 0.5


def test_a_track_array_keeps_each_tracking_id_and_its_position_covariance():
    track = Track(id=42, x=101.0, y=151.0, label="person", score=0.9)
    track.position_covariance = [4.0, 1.0, 1.0, 9.0]
    track.bbox.x, track.bbox.y, track.bbox.width, track.bbox.height = 90.0, 120.0, 22.0, 62.0
    vision = tracks_to_vision(TrackArray(tracks=[track]))
    (detection,) = vision.detections
    assert detection.id == "42" and detection.results[0].hypothesis.class_id == "person"
    pose = detection.results[0].pose
    assert (pose.pose.position.x, pose.pose.position.y) == (101.0, 151.0)
    assert [pose.covariance[i] for i in (0, 1, 6, 7)] == [4.0, 1.0, 1.0, 9.0]


def people(stamp_ns, k):
    msg = BlobArray(
        target_present=True, blobs=[blob(100.0 + 8 * k, 150.0), blob(260.0 - 8 * k, 90.0)]
    )
    msg.header.stamp, msg.header.frame_id = ns_to_stamp(stamp_ns), "scene"
    return msg


def test_a_vision_msgs_consumer_gets_every_frames_tracks_with_the_suites_ids():
    h = NodeHarness(
        TrackerNode,
        inputs={"detections": (BlobArray, 50)},
        outputs={
            "tracks": (TrackArray, result_qos()),
            "tracks_2d": (Detection2DArray, result_qos()),
        },
    )
    try:
        h.spin_until(lambda: h.node._vision_pub.get_subscription_count() == 1)
        for k in range(8):
            h.feed("detections", people(k * NS, k))
        h.spin_until(lambda: len(h.received["tracks_2d"]) == 8 and len(h.received["tracks"]) == 8)
        for suite, vision in zip(h.received["tracks"], h.received["tracks_2d"], strict=True):
            assert vision.header == suite.header
            assert [d.id for d in vision.detections] == [str(t.id) for t in suite.tracks]
            labels = [d.results[0].hypothesis.class_id for d in vision.detections]
            assert labels == [t.label for t in suite.tracks]
        assert any(vision.detections for vision in h.received["tracks_2d"])
    finally:
        h.close()
