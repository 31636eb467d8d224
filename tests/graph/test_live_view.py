"""The live view node serves the graph to the Foxglove app: a WebSocket client receives every
channel (camera and scene images, their annotations, the pan-tilt state)."""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("foxglove")

from foxglove_client import FoxgloveClient  # noqa: E402
from node_harness import NodeHarness  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402

from tracker_msgs.msg import BlobArray, PtzState, Target, Track, TrackArray  # noqa: E402
from tracker_msgs_py.codec import array_to_image, image_qos, ns_to_stamp, result_qos  # noqa: E402
from tracker_ptz_sim.bringup.live_view_node import LiveViewNode  # noqa: E402

pytestmark = pytest.mark.ros
CHANNELS = {
    "/camera/image",
    "/camera/annotations",
    "/scene/image",
    "/scene/annotations",
    "/ptz/state",
}


def frame_messages(stamp_ns: int):
    stamp = ns_to_stamp(stamp_ns)
    scene = array_to_image(np.full((480, 640, 3), 90, np.uint8), "bgr8", stamp, "scene")
    view = array_to_image(np.full((264, 264, 3), 90, np.uint8), "bgr8", stamp, "camera")
    state = PtzState(pan=0.1, tilt=0.0, zoom=1.0, focal_length=440.0)
    state.window.x, state.window.y, state.window.width, state.window.height = (
        188.0,
        108.0,
        264.0,
        264.0,
    )
    state.header.stamp = stamp
    detections = BlobArray()
    detections.header.stamp = stamp
    tracks = TrackArray()
    tracks.header.stamp = stamp
    track = Track(id=3, status=Track.STATUS_CONFIRMED, x=300.0, y=250.0)
    track.bbox.x, track.bbox.y, track.bbox.width, track.bbox.height = 290.0, 200.0, 20.0, 60.0
    tracks.tracks = [track]
    target = Target(locked=True, track=track)
    target.header.stamp = stamp
    return scene, view, state, detections, tracks, target


def test_a_foxglove_client_receives_every_channel():
    h = NodeHarness(
        LiveViewNode,
        inputs={
            "scene/image_raw": (Image, image_qos(False)),
            "camera/image_raw": (Image, image_qos(False)),
            "ptz/state": (PtzState, result_qos()),
            "detections": (BlobArray, result_qos()),
            "tracks": (TrackArray, result_qos()),
            "target": (Target, result_qos()),
        },
        outputs={},
        port=0,
    )
    client = FoxgloveClient(h.node.view.port)
    try:
        client.wait_for_channels(CHANNELS)
        h.spin_for(0.2)  # the subscription reaches the server
        for frame in range(3):
            scene, view, state, detections, tracks, target = frame_messages(frame * 100_000_000)
            for topic, msg in [
                ("scene/image_raw", scene),
                ("camera/image_raw", view),
                ("ptz/state", state),
                ("detections", detections),
                ("tracks", tracks),
                ("target", target),
            ]:
                h.publish(topic, msg)
            h.spin_for(0.1)
        client.wait_for_messages(CHANNELS)
        jpeg = client.messages["/camera/image"][0]
        assert b"\xff\xd8\xff" in jpeg  # the CompressedImage carries a JPEG
    finally:
        client.close()
        h.close()


def test_run_demo_live_serves_the_running_graph(tmp_path):
    """`run_demo --live` (make demo LIVE=1): while the replay runs, a Foxglove client receives
    every channel of the graph's live view."""
    import socket
    import subprocess
    import time

    from ros_process import executable

    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    scene = generate_scene(SceneConfig(width=640, height=480, num_frames=60, num_objects=1, seed=9))
    paths = write_scene(scene, tmp_path / "scene")
    with socket.socket() as probe:  # a free port for the view
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    command = [str(executable("tracker_ptz_sim", "run_demo")), "--video", str(paths.video)]
    command += ["--out", str(tmp_path / "run"), "--no-video", "--live"]
    command += ["--set", f"live_view.port={port}", "--set", "video_source.rate=1.0"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 60
        client = None
        while client is None:
            assert time.monotonic() < deadline and process.poll() is None, "no live view"
            try:
                client = FoxgloveClient(port)
            except OSError:
                time.sleep(0.2)
        try:
            client.wait_for_channels(CHANNELS, timeout=30)
            client.wait_for_messages(CHANNELS, timeout=30)
        finally:
            client.close()
        output, _ = process.communicate(timeout=120)
        assert process.returncode == 0, output
        assert f"live view: open ws://127.0.0.1:{port}" in output
    finally:
        process.kill()
