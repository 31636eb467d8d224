"""video_source -> ptz_camera as separate processes, with this test playing the controller."""

from __future__ import annotations

import hashlib
import time

import numpy as np
import pytest
from ros_process import RosProcess

pytestmark = pytest.mark.ros

FRAMES = 24
# Commands the test sends, by frame: every border, velocity moves, a hold.
PLAN = {
    0: ("position", 5.0, 0.0),  # far left: clamped at x = 0
    4: ("position", -5.0, 0.0),  # far right
    8: ("position", 0.0, -5.0),  # top
    12: ("position", 0.0, 5.0),  # bottom
    16: ("velocity", -0.4, 0.2),
    20: ("hold", 0.0, 0.0),
}


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    scene = generate_scene(
        SceneConfig(width=320, height=240, num_frames=FRAMES, num_objects=2, seed=3)
    )
    paths = write_scene(scene, tmp_path_factory.mktemp("scene"))
    return scene, paths


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class Controller:
    """A stand-in for ptz_controller: acknowledges every camera image with the planned command."""

    def __init__(self, instant: bool = True):
        import rclpy
        from rclpy.node import Node
        from sensor_msgs.msg import Image, JointState

        from tracker_msgs.msg import PtzCommand, PtzState, ReplayStatus
        from tracker_msgs_py.codec import image_qos
        from tracker_ptz_sim.simulation.video_source_node import STATUS_QOS

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node("test_controller", context=self.context)
        self.views, self.states, self.joints, self.statuses = {}, {}, {}, []
        self.PtzCommand = PtzCommand
        self.command_pub = self.node.create_publisher(PtzCommand, "ptz/command", 10)
        self.node.create_subscription(Image, "camera/image_raw", self._on_view, image_qos(True))
        self.node.create_subscription(PtzState, "ptz/state", self._on_state, 10)
        self.node.create_subscription(JointState, "ptz/joint_states", self._on_joints, 10)
        self.node.create_subscription(
            ReplayStatus, "replay/status", self.statuses.append, STATUS_QOS
        )
        self.pending: list = []
        # as run_demo's recorder: says which scene images arrived (while `recording`)
        from std_msgs.msg import Header

        self.Header = Header
        self.recorded_pub = self.node.create_publisher(Header, "replay/recorded", 10)
        self.node.create_subscription(Image, "scene/image_raw", self._on_scene, image_qos(True))
        self.scenes: list = []
        self.recording = True

    def _on_scene(self, msg):
        self.scenes.append(msg.header.stamp)

    def _on_view(self, msg):
        from tracker_msgs_py.codec import image_to_array, stamp_to_ns

        stamp = stamp_to_ns(msg.header.stamp)
        self.views[stamp] = image_to_array(msg).copy()
        self.pending.append(msg.header.stamp)

    def _on_state(self, msg):
        from tracker_msgs_py.codec import stamp_to_ns

        self.states[stamp_to_ns(msg.header.stamp)] = msg

    def _on_joints(self, msg):
        from tracker_msgs_py.codec import stamp_to_ns

        self.joints[stamp_to_ns(msg.header.stamp)] = msg

    def acknowledge(self):
        """Answer each camera image with the command planned for its frame (the latest PLAN
        entry at or before it, so velocity commands are refreshed every frame), and each scene
        image with a recorder's acknowledgement while `recording`."""
        while self.recording and self.scenes:
            self.recorded_pub.publish(self.Header(stamp=self.scenes.pop(0)))
        PtzCommand = self.PtzCommand
        while self.pending:
            stamp = self.pending.pop(0)
            frame = sorted(self.views).index(stamp_ns(stamp))
            mode, a, b = PLAN[max(k for k in PLAN if k <= frame)]
            msg = PtzCommand()
            msg.header.stamp = stamp
            if mode == "position":
                msg.mode, msg.pan, msg.tilt = PtzCommand.MODE_POSITION, a, b
            elif mode == "velocity":
                msg.mode, msg.pan_rate, msg.tilt_rate = PtzCommand.MODE_VELOCITY, a, b
            else:
                msg.mode = PtzCommand.MODE_HOLD
            self.command_pub.publish(msg)

    def run_until(self, done, timeout=60.0):
        deadline = time.monotonic() + timeout
        while not done() and time.monotonic() < deadline:
            self._spin()
            self.acknowledge()

    def _spin(self):
        from rclpy.executors import SingleThreadedExecutor

        if not hasattr(self, "executor"):
            self.executor = SingleThreadedExecutor(context=self.context)
            self.executor.add_node(self.node)
        self.executor.spin_once(timeout_sec=0.02)

    def close(self):
        self.node.destroy_node()
        self.context.try_shutdown()


def replay(paths, tmp_path, servo="instant", in_flight=1, before_acks=None, recorder=False):
    """One lockstep replay with `in_flight` frames in flight (the camera delaying commands as
    many frames); the views, states, joint states and statuses received. `before_acks(controller)`
    runs once the replay has started, before any image is acknowledged."""
    controller = Controller()
    common = {"lockstep": True, "reliable_images": True}
    camera = RosProcess(
        "tracker_ptz_sim",
        "ptz_camera",
        log_dir=tmp_path,
        params={**common, "servo": servo, "command_delay_frames": in_flight},
    )
    # Frame 0 must not be lost: start the replay once the camera and this test see each other.
    controller.run_until(
        lambda: (
            controller.node.count_publishers("camera/image_raw") > 0
            and controller.node.count_subscribers("ptz/command") > 0
        ),
        timeout=20.0,
    )
    source = RosProcess(
        "tracker_ptz_sim",
        "video_source",
        log_dir=tmp_path,
        params={
            **common,
            "path": str(paths.video),
            "rate": 0.0,
            "wait_for_subscribers": 2,  # the camera and this test's recorder stand-in
            "frames_in_flight": in_flight,
            **({"recorder_topic": "replay/recorded"} if recorder else {}),
        },
    )
    try:
        if before_acks is not None:
            before_acks(controller)
        controller.run_until(
            lambda: source.process.poll() is not None and len(controller.views) >= FRAMES
        )
        controller.run_until(lambda: any(s.state == 1 for s in controller.statuses), timeout=5.0)
        assert source.wait(timeout=10) == 0, source.output()
        return controller.views, controller.states, controller.joints, controller.statuses
    finally:
        camera.interrupt(timeout=5)
        camera.kill()
        source.kill()
        controller.close()


def test_lockstep_views_are_exact_slices_at_the_reported_windows(scene, tmp_path):
    scene, paths = scene
    views, states, joints, statuses = replay(paths, tmp_path)
    stamps = scene.stamps_ns()
    assert sorted(views) == stamps, "every frame reaches the camera, in lockstep"
    borders = set()
    for index, stamp in enumerate(stamps):
        state, view = states[stamp], views[stamp]
        w = state.window
        x, y, width, height = int(w.x), int(w.y), int(w.width), int(w.height)
        assert (x, y, width, height) == (w.x, w.y, w.width, w.height)
        assert np.array_equal(view, scene.frames[index][y : y + height, x : x + width])
        # joint states and window agree through x = cx - f pan, y = cy + f tilt
        pan, tilt = joints[stamp].position
        assert (pan, tilt) == (state.pan, state.tilt)
        assert 160 - state.focal_length * pan == pytest.approx(w.x + w.width / 2)
        assert 120 + state.focal_length * tilt == pytest.approx(w.y + w.height / 2)
        assert list(joints[stamp].name) == ["pan_joint", "tilt_joint"]
        borders |= {
            name
            for name, hit in [
                ("left", x == 0),
                ("right", x + width == 320),
                ("top", y == 0),
                ("bottom", y + height == 240),
            ]
            if hit
        }
    assert borders == {"left", "right", "top", "bottom"}
    ended = statuses[-1]
    assert ended.state == ended.STATE_ENDED and ended.frames_published == FRAMES
    assert ended.lockstep_timeouts == 0 and ended.frames_skipped == 0


def test_two_lockstep_replays_are_identical(scene, tmp_path):
    _, paths = scene

    def digest(run):
        views, states, _, _ = run
        h = hashlib.sha256()
        for stamp in sorted(views):
            s = states[stamp]
            h.update(views[stamp].tobytes())
            h.update(
                repr(
                    (stamp, s.pan, s.tilt, s.pan_rate, s.tilt_rate, s.window.x, s.window.y)
                ).encode()
            )
        return h.hexdigest()

    first = digest(replay(paths, tmp_path / "a", servo="dynamic"))
    second = digest(replay(paths, tmp_path / "b", servo="dynamic"))
    assert first == second


def test_bag_replays_with_identical_pixels_and_stamps(scene, tmp_path):
    from rclpy.serialization import serialize_message

    from tracker_msgs_py.codec import array_to_image, ns_to_stamp
    from tracker_ptz_sim.evaluation.recording import BagWriter

    scene, _ = scene
    bag = tmp_path / "bag"
    writer = BagWriter(bag, {"/cam/image": "sensor_msgs/msg/Image"})
    stamps = [
        1_700_000_000_000_000_000 + 40_000_000 * i for i in range(FRAMES)
    ]  # 25 fps, epoch time
    for frame, stamp in zip(scene.frames, stamps, strict=True):
        writer.write(
            "/cam/image",
            stamp,
            serialize_message(array_to_image(frame, "bgr8", ns_to_stamp(stamp), "c")),
        )
    writer.close()
    received = {}
    controller = Controller()

    def on_scene(msg):
        from tracker_msgs_py.codec import image_to_array, stamp_to_ns

        received[stamp_to_ns(msg.header.stamp)] = image_to_array(msg).copy()
        ack = controller.PtzCommand()
        ack.header.stamp = msg.header.stamp
        controller.command_pub.publish(ack)

    from sensor_msgs.msg import Image

    from tracker_msgs_py.codec import image_qos

    controller.node.create_subscription(Image, "scene/image_raw", on_scene, image_qos(True))
    source = RosProcess(
        "tracker_ptz_sim",
        "video_source",
        log_dir=tmp_path,
        params={"path": str(bag), "lockstep": True, "reliable_images": True, "rate": 0.0},
    )
    try:
        deadline = time.monotonic() + 60
        while source.process.poll() is None and time.monotonic() < deadline:
            controller._spin()
        assert source.wait(timeout=5) == 0, source.output()
    finally:
        source.kill()
        controller.close()
    assert sorted(received) == stamps
    for frame, stamp in zip(scene.frames, stamps, strict=True):
        assert np.array_equal(received[stamp], frame)


@pytest.mark.parametrize(
    "case",
    [
        "missing",
        "unknown_format",
        "empty_folder",
        "empty_bag_topic",
        "empty_path",
        "start_past_end",
        "start_past_end_looping",
        "end_before_start",
        "mp4_without_index",
        "unreadable_images",
    ],
)
def test_bad_inputs_exit_with_one_clear_error(case, scene, tmp_path):
    params = {}
    if case == "missing":
        path, expected = tmp_path / "nope.mp4", "no such file"
    elif case == "unknown_format":
        path, expected = tmp_path / "notes.avi", "not a video OpenCV can read"
        path.write_text("this is not a video")
    elif case == "empty_folder":
        path, expected = tmp_path / "frames", "no images"
        path.mkdir()
    elif case == "empty_bag_topic":
        from tracker_ptz_sim.evaluation.recording import BagWriter

        path, expected = tmp_path / "bag", "no Image or CompressedImage topic"
        BagWriter(path, {"/status": "tracker_msgs/msg/ReplayStatus"}).close()
    elif case == "empty_path":
        path, expected = "", "no input"  # not the current directory
    elif case == "unreadable_images":
        path, expected = tmp_path / "frames", "no frame could be read"
        path.mkdir()
        for name in ("000.png", "001.png"):
            (path / name).write_bytes(b"not a png")
    elif case == "mp4_without_index":
        path, expected = clip(tmp_path / "unfinished.mp4", "mp4v", 30), "'moov' atom not found"
        data = path.read_bytes()
        path.write_bytes(data[: data.index(b"moov") - 4])  # a recording never finalised
    else:
        path = scene[1].video  # FRAMES frames
        params = {
            "start_past_end": {"start_frame": FRAMES},
            "start_past_end_looping": {"start_frame": FRAMES + 5, "loop": True},
            "end_before_start": {"start_frame": 5, "end_frame": 5},
        }[case]
        expected = "must be greater than" if case == "end_before_start" else "past the end"
    source = RosProcess(
        "tracker_ptz_sim",
        "video_source",
        log_dir=tmp_path,
        params={"path": str(path) if path else '""', **params},
    )
    try:
        code = source.wait(timeout=20)
    finally:
        source.kill()
    output = source.output()
    assert code == 2, output
    assert expected in output and str(path) in output
    assert "Traceback" not in output and output.count("[FATAL]") == 1


def clip(path, fourcc, count):
    import cv2

    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), 10.0, (64, 48))
    for k in range(count):
        writer.write(np.full((48, 64, 3), (k * 5) % 250, np.uint8))
    writer.release()
    return path


def test_a_truncated_video_reports_the_frames_it_lost(tmp_path):
    from node_harness import NodeHarness
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from tracker_msgs.msg import ReplayStatus
    from tracker_ptz_sim.simulation.video_source_node import VideoSourceNode

    video = clip(tmp_path / "cut.avi", "MJPG", 80)
    data = video.read_bytes()
    video.write_bytes(data[: len(data) // 2])  # the recorder died half way
    status_qos = QoSProfile(
        depth=10,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    h = NodeHarness(
        VideoSourceNode,
        inputs={},
        outputs={"replay/status": (ReplayStatus, status_qos)},
        path=str(video),
        rate=0.0,
        publish_clock=False,
    )
    try:
        h.spin_until(lambda: h.node.finished.is_set(), timeout=20.0)
        h.spin_until(lambda: h.received["replay/status"][-1].state == ReplayStatus.STATE_ENDED)
    finally:
        h.close()
    final = h.received["replay/status"][-1]
    assert h.node.exit_code == 0
    assert 0 < final.frames_published < 80 and final.frames_lost > 0
    assert final.frames_published + final.frames_skipped + final.frames_lost == 80
    assert "could not be read (the file looks truncated)" in final.message


def test_changing_the_rate_during_a_replay_neither_bursts_nor_stalls(tmp_path):
    """Pacing continues from the moment of the change (it used to restart from the loop's start:
    a burst of catch-up frames when speeding up, a long stall when slowing down)."""
    from node_harness import NodeHarness
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Image

    from tracker_msgs_py.codec import image_qos
    from tracker_ptz_sim.simulation.video_source_node import VideoSourceNode

    video = clip(tmp_path / "clip.avi", "MJPG", 200)
    arrivals = []
    h = NodeHarness(
        VideoSourceNode,
        inputs={},
        outputs={"scene/image_raw": (Image, image_qos(True))},
        path=str(video),
        rate=1.0,
        reliable_images=True,
        publish_clock=False,
    )
    h.peer.create_subscription(
        Image, "scene/image_raw", lambda _: arrivals.append(time.monotonic()), image_qos(True)
    )
    client = h.peer.create_client(SetParameters, "video_source/set_parameters")

    def set_rate(rate):
        future = client.call_async(
            SetParameters.Request(parameters=[Parameter("rate", value=rate).to_parameter_msg()])
        )
        h.spin_until(future.done)
        assert future.result().results[0].successful
        return time.monotonic()

    try:
        h.spin_until(lambda: len(arrivals) >= 15, timeout=10.0)  # 1.5 s of replay at 10 fps
        changed = set_rate(5.0)
        h.spin_until(lambda: len(arrivals) >= 40, timeout=10.0)
        after = [t for t in arrivals if t > changed]
        # 5x: about 50 frames/s. A catch-up burst would send ~15 frames at once.
        assert sum(1 for t in after if t < changed + 0.2) <= 10 + 3
        slowed = set_rate(0.1)  # a frame every second from now on
        count = len(arrivals)
        h.spin_until(lambda: len(arrivals) > count + 1, timeout=5.0)  # not a 10 s stall
        assert arrivals[count + 1] - slowed < 3.0
    finally:
        h.close()


def test_corrupt_frame_is_skipped_and_counted(scene, tmp_path):
    import cv2

    scene, _ = scene
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(6):
        cv2.imwrite(str(folder / f"img{i + 1}.png"), scene.frames[i])
    (folder / "img3.png").write_bytes(b"\x89PNG broken")
    from tracker_ptz_sim.simulation.frame_sources import open_source

    source = open_source(folder)
    frames = list(source.frames())
    assert [f.index for f in frames] == [0, 1, 3, 4, 5] and source.skipped == 1
    assert np.array_equal(frames[2].image, scene.frames[3])


def test_a_pipelined_replay_keeps_its_frames_in_flight_and_delays_commands_as_many(scene, tmp_path):
    """frames_in_flight 3: three frames go out before any acknowledgement; the camera applies
    each command three frames after the image it answers, and nothing times out."""
    scene, paths = scene
    unanswered = {}

    def hold_acks(controller):
        deadline = time.monotonic() + 20
        while not controller.views and time.monotonic() < deadline:
            controller._spin()
        end = time.monotonic() + 0.5  # well within the source's lockstep_timeout (2 s)
        while time.monotonic() < end:
            controller._spin()
        unanswered["views"] = len(controller.views)

    views, states, _, statuses = replay(paths, tmp_path, in_flight=3, before_acks=hold_acks)
    assert unanswered["views"] == 3
    stamps = scene.stamps_ns()
    assert sorted(views) == stamps
    xs = [states[stamp].window.x for stamp in stamps]
    assert xs[:3] == [xs[0]] * 3 and xs[0] > 0  # frame 0's command (far left) ...
    assert xs[3] == 0  # ... acts from frame 3
    ended = statuses[-1]
    assert ended.state == ended.STATE_ENDED and ended.frames_published == FRAMES
    assert ended.lockstep_timeouts == 0


def test_a_replay_with_a_recorder_waits_for_it_too(scene, tmp_path):
    """recorder_topic: a frame the controller has answered still waits until the recorder has
    it, so a recorder that falls behind slows the replay instead of losing frames."""
    scene, paths = scene
    held = {}

    def stall_the_recorder(controller):
        controller.recording = False
        deadline = time.monotonic() + 20
        while not controller.views and time.monotonic() < deadline:
            controller._spin()
        end = time.monotonic() + 0.5  # the commands are answered; the recorder is silent
        while time.monotonic() < end:
            controller._spin()
            controller.acknowledge()
        held["views"] = len(controller.views)
        controller.recording = True

    views, _, _, statuses = replay(paths, tmp_path, before_acks=stall_the_recorder, recorder=True)
    assert held["views"] == 1  # in series: frame 1 waited for frame 0's recording
    assert sorted(views) == scene.stamps_ns()
    ended = statuses[-1]
    assert ended.state == ended.STATE_ENDED and ended.frames_published == FRAMES
    assert ended.lockstep_timeouts == 0
