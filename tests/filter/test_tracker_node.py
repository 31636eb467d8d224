"""The tracker node: one TrackArray and one Target per BlobArray, stamps, services, parameters,
bad input, and the executable's start-up / shutdown behaviour."""

import os
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from hostile_messages import (  # noqa: E402
    Field,
    HostileSource,
    assert_unchanged_by_hostile_messages,
    feed_hostile,
    record_publishes,
)
from node_harness import NodeHarness  # noqa: E402
from rcl_interfaces.srv import SetParameters, SetParametersAtomically  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from tracker_filter.tracker_node import TrackerNode  # noqa: E402
from tracker_msgs.msg import Blob, BlobArray, PtzState, Target, TrackArray  # noqa: E402
from tracker_msgs.srv import ResetTracker, SelectTarget  # noqa: E402
from tracker_msgs_py.codec import ns_to_stamp  # noqa: E402

pytestmark = pytest.mark.ros
ROOT = Path(__file__).resolve().parents[2]
EXECUTABLE = ROOT / "install" / "tracker_filter" / "lib" / "tracker_filter" / "tracker"


class Harness:
    """The tracker node and a test node on a private context, spun by hand."""

    def __init__(self, overrides=()):
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.tracker = TrackerNode(context=self.context, parameter_overrides=list(overrides))
        self.node = rclpy.create_node("tracker_test", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.tracker)
        self.executor.add_node(self.node)
        self.tracks, self.targets = [], []
        self.node.create_subscription(TrackArray, "tracks", self.tracks.append, 50)
        self.node.create_subscription(Target, "target", self.targets.append, 50)
        self.detections = self.node.create_publisher(BlobArray, "detections", 50)
        self.ptz = self.node.create_publisher(PtzState, "ptz/state", 10)
        self.wait(
            lambda: (
                self.detections.get_subscription_count() > 0
                and self.tracker.count_subscribers("target") > 0
            )
        )

    def wait(self, condition, timeout=10.0):
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, "timed out"
            self.executor.spin_once(timeout_sec=0.05)

    def send(self, stamp_s, positions, present=True, frame_id="scene", label="person"):
        """Blobs at `positions`, of a person detector unless `label` says otherwise."""
        msg = BlobArray(target_present=present)
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(stamp_s), round((stamp_s % 1) * 1e9)
        msg.header.frame_id = frame_id
        for x, y in positions:
            blob = Blob(centroid_x=float(x), centroid_y=float(y), area=100, label=label)
            blob.bbox.x, blob.bbox.y, blob.bbox.width, blob.bbox.height = (
                x - 5.0,
                y - 5.0,
                10.0,
                10.0,
            )
            msg.blobs.append(blob)
        expected = len(self.targets) + 1
        self.detections.publish(msg)
        self.wait(lambda: len(self.tracks) >= expected and len(self.targets) >= expected)
        return self.tracks[-1], self.targets[-1]

    def call(self, service_type, name, request):
        client = self.node.create_client(service_type, name)
        assert client.wait_for_service(timeout_sec=5.0)
        future = client.call_async(request)
        self.wait(future.done)
        return future.result()

    def set_parameters(self, **values):
        request = SetParameters.Request(
            parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()]
        )
        return self.call(SetParameters, "tracker/set_parameters", request).results

    def set_parameters_atomically(self, **values):
        parameters = [Parameter(k, value=v).to_parameter_msg() for k, v in values.items()]
        request = SetParametersAtomically.Request(parameters=parameters)
        return self.call(
            SetParametersAtomically, "tracker/set_parameters_atomically", request
        ).result

    def close(self):
        self.executor.shutdown()
        self.tracker.destroy_node()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture
def harness():
    h = Harness()
    yield h
    h.close()


def stamp_s(header):
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def test_one_output_of_each_per_frame_with_the_frame_stamp(harness):
    outputs = []
    frames = [
        (10.0, [(100, 100)], True),
        (10.12, [], True),  # empty
        (10.24, [(110, 100), (float("nan"), 5.0)], True),  # the NaN blob is rejected
        (10.36, [(115, 100)], True),  # 3 hits in 4 frames: confirmed
        (10.48, [(120, 100)], False),  # presence test failed: no measurement
        (10.60, [(125, 100)], True),
    ]
    for t, blobs, present in frames:
        outputs.append(harness.send(t, blobs, present))
    for (t, _, _), (tracks, target) in zip(frames, outputs, strict=True):
        assert stamp_s(tracks.header) == pytest.approx(t) and stamp_s(
            target.header
        ) == pytest.approx(t)
        assert tracks.header.frame_id == target.header.frame_id == "scene"
    assert [[t.id for t in tracks.tracks] for tracks, _ in outputs] == [[1]] * 6
    assert [tracks.tracks[0].hits for tracks, _ in outputs] == [1, 1, 2, 3, 3, 4]
    assert [target.locked for _, target in outputs] == [False, False, False, True, True, True]
    assert outputs[4][1].track.status == outputs[4][1].track.STATUS_COASTING
    track = outputs[-1][1].track
    assert (
        track.id == 1
        and track.status == track.STATUS_CONFIRMED
        and track.state_layout == "x y vx vy"
    )
    assert len(track.state) == 4 and len(track.covariance) == 16
    target = outputs[-1][1]
    assert target.selection == Target.SELECT_LONGEST_LIVED and target.lead_time == pytest.approx(
        0.12
    )
    assert target.predicted_x == pytest.approx(track.x + track.vx * 0.12)
    assert harness.tracker._tracker.rejected_measurements == 1


def test_a_repeated_frame_is_dropped_and_a_jump_back_starts_a_new_epoch(harness):
    for k in range(4):
        _, target = harness.send(5.0 + 0.1 * k, [(100 + 5 * k, 50)])
    assert target.locked and target.track.id == 1
    repeat = BlobArray(target_present=True)
    repeat.header.stamp.sec, repeat.header.stamp.nanosec = 5, 300_000_000
    harness.detections.publish(repeat)
    harness.wait(lambda: harness.tracker.problems.count("repeat detections stamp") == 1)
    assert len(harness.targets) == 4  # not answered: the frame was tracked once already
    # A restarted replay: the old tracks go, ids continue, the new time base is accepted.
    tracks, target = harness.send(0.5, [(500, 500)])
    assert [t.id for t in tracks.tracks] == [2] and not target.locked
    for k in range(1, 4):
        tracks, target = harness.send(0.5 + 0.1 * k, [(500 + 5 * k, 500)])
    assert target.locked and target.track.id == 2 and target.track.hits == 4


def test_tracks_carry_their_label_and_only_people_are_followed_by_default(harness):
    for k in range(5):
        tracks, target = harness.send(20.0 + 0.1 * k, [(100 + 3 * k, 100)], label="motion")
    assert [(t.label, t.status) for t in tracks.tracks] == [("motion", 1)]
    assert not target.locked  # a flag, a tree or a car is tracked, never followed
    for k in range(5):
        tracks, target = harness.send(21.0 + 0.1 * k, [(300 + 3 * k, 100)])
    assert target.locked and target.track.label == "person"
    assert {t.label for t in tracks.tracks} == {"motion", "person"}


def test_track_labels_names_what_the_camera_may_follow():
    harness = Harness([Parameter("track_labels", value=["any"])])
    try:
        for k in range(5):
            _, target = harness.send(20.0 + 0.1 * k, [(100 + 3 * k, 100)], label="motion")
        assert target.locked and target.track.label == "motion"
    finally:
        harness.close()


def test_hostile_blobs_never_become_tracks(harness, capfd):
    """Blobs beyond 1e6 px, with a NaN score or angle, an infinite oriented size, a negative
    box: dropped with one line per cause. A frame of nothing else is refused whole (not
    answered) before its stamp counts, even 1000 s ahead: good detections afterwards are tracked
    as on a fresh tracker."""
    hostile = [
        dict(centroid_x=1e308, centroid_y=50.0),
        dict(centroid_x=200.0, centroid_y=50.0, score=float("nan")),
        dict(centroid_x=300.0, centroid_y=50.0, width=-10.0),
        dict(centroid_x=400.0, centroid_y=50.0, angle=float("nan")),
        dict(centroid_x=500.0, centroid_y=50.0, oriented_width=float("inf")),
    ]
    for k in range(4):
        msg = BlobArray(target_present=True)
        msg.header.stamp.sec, msg.header.stamp.nanosec = 1 + 1000 * (k == 3), 100_000_000 * k
        for fields in hostile:
            blob = Blob(centroid_x=fields["centroid_x"], centroid_y=fields["centroid_y"], area=100)
            blob.score = fields.get("score", 0.2)
            blob.bbox.x, blob.bbox.y = fields["centroid_x"] - 5.0, fields["centroid_y"] - 5.0
            blob.bbox.width, blob.bbox.height = fields.get("width", 10.0), 10.0
            blob.angle = fields.get("angle", 0.0)
            blob.oriented_width = fields.get("oriented_width", 0.0)
            msg.blobs.append(blob)
        harness.detections.publish(msg)
        harness.wait(lambda n=k + 1: harness.tracker.problems.count("no usable detection") == n)
    assert harness.tracks == [] and harness.targets == []
    assert harness.tracker.problems.counts == {
        "unusable oriented box": 8,
        "no usable detection": 4,
    }
    err = capfd.readouterr().err
    assert err.count("angle or oriented size is not finite, beyond 1e+06 or negative") == 1
    assert err.count("none of their 5 blobs can be a measurement") == 1
    for k in range(4):  # good detections afterwards are tracked as on a fresh tracker
        tracks, target = harness.send(2.0 + 0.1 * k, [(100 + 5 * k, 50)])
    assert [t.id for t in tracks.tracks] == [1] and target.locked
    assert harness.tracker._order.epochs == 0  # the frame 1000 s ahead moved no clock


def test_services_select_and_reset(harness):
    for k in range(4):
        tracks, target = harness.send(1.0 + 0.1 * k, [(100 + 5 * k, 50), (400, 300 + 5 * k)])
    assert target.locked and target.track.id == 1
    response = harness.call(
        SelectTarget,
        "tracker/select_target",
        SelectTarget.Request(mode=SelectTarget.Request.MODE_TRACK_ID, track_id=2),
    )
    assert response.success and response.selected_track_id == 2
    _, target = harness.send(1.4, [(120, 50), (400, 320)])
    assert target.track.id == 2 and target.selection == Target.SELECT_MANUAL_ID
    bad = harness.call(
        SelectTarget,
        "tracker/select_target",
        SelectTarget.Request(mode=SelectTarget.Request.MODE_TRACK_ID, track_id=77),
    )
    assert not bad.success and "77" in bad.message
    rect_request = SelectTarget.Request(mode=SelectTarget.Request.MODE_RECTANGLE)
    (
        rect_request.rectangle.x,
        rect_request.rectangle.y,
        rect_request.rectangle.width,
        rect_request.rectangle.height,
    ) = 110.0, 40.0, 30.0, 20.0
    response = harness.call(SelectTarget, "tracker/select_target", rect_request)
    assert response.success and response.selected_track_id == 1
    rect_request.rectangle.width = float("nan")
    assert not harness.call(SelectTarget, "tracker/select_target", rect_request).success
    reset = harness.call(
        ResetTracker, "tracker/reset_tracker", ResetTracker.Request(reset_ids=True)
    )
    assert reset.success and reset.tracks_cleared == 2
    tracks, target = harness.send(0.5, [(10, 10)])  # an earlier stamp is fine after a reset
    assert [t.id for t in tracks.tracks] == [1] and not target.locked


def test_nearest_centre_uses_the_ptz_window(harness):
    assert all(
        r.successful
        for r in harness.set_parameters(selection_policy="nearest_centre", min_lock_time=0.0)
    )
    state = PtzState()
    state.window.x, state.window.y, state.window.width, state.window.height = (
        350.0,
        250.0,
        110.0,
        110.0,
    )
    harness.ptz.publish(state)
    harness.wait(lambda: harness.tracker._view_centre is not None)
    for k in range(4):
        _, target = harness.send(2.0 + 0.1 * k, [(100, 100), (400, 300)])
    assert target.locked and (target.track.x, target.track.y) == pytest.approx((400, 300), abs=1.0)
    assert target.selection == Target.SELECT_NEAREST_CENTRE


def test_parameter_changes_are_validated(harness):
    for k in range(4):
        harness.send(3.0 + 0.1 * k, [(100, 100)])
    rejected = harness.set_parameters(confirm_hits=9)
    assert not rejected[0].successful and "confirm_window" in rejected[0].reason
    rejected = harness.set_parameters_atomically(filter="alpha_beta", gain_rule="free", beta=3.0)
    assert not rejected.successful and "unstable" in rejected.reason
    rejected = harness.set_parameters(alpha=1.7)  # checked even while the Kalman filter runs
    assert not rejected[0].successful and "alpha" in rejected[0].reason
    assert harness.tracker.get_parameter("filter").value == "kalman_cv"
    tracks, _ = harness.send(3.4, [(100, 100)])
    assert tracks.tracks[0].hits == 5  # rejected changes left the tracks alone
    assert all(r.successful for r in harness.set_parameters(lead_time=0.5))
    tracks, target = harness.send(3.5, [(100, 100)])
    assert target.lead_time == 0.5 and tracks.tracks[0].hits == 6  # live change: tracks kept
    assert all(r.successful for r in harness.set_parameters(filter="alpha_beta_gamma", alpha=0.5))
    tracks, _ = harness.send(3.6, [(100, 100)])
    track = tracks.tracks[0]
    assert track.id == 2 and track.state_layout == "x y vx vy ax ay"  # rebuilt, ids continue


def test_a_change_that_needs_other_inputs_is_refused():
    """The foreground cue (on by default) needs the motion mask; the topics are chosen at start."""
    harness = Harness([Parameter("method", value="colour_particles")])
    try:
        rejected = harness.set_parameters(foreground_power=0.0)
        assert not rejected[0].successful and "restart the node" in rejected[0].reason
        assert all(r.successful for r in harness.set_parameters(size_noise=0.02))
    finally:
        harness.close()


def test_seed_preset_tracks_the_largest_blob_from_the_first_frame():
    h = Harness([Parameter("preset", value="seed000")])
    try:
        tracks, target = h.send(1.0, [(50, 50), (200, 100)])
        assert (
            len(tracks.tracks) == 1
            and target.locked
            and target.selection == Target.SELECT_LARGEST_BLOB
        )
        assert target.lead_time == 0.0 and h.tracker.get_parameter("max_misses").value == 4
    finally:
        h.close()


@pytest.mark.skipif(not EXECUTABLE.exists(), reason="workspace not built")
def test_executable_exits_cleanly_on_sigint_and_with_2_on_bad_parameters():
    env = dict(os.environ)
    process = subprocess.Popen(
        [str(EXECUTABLE)], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    try:
        deadline = time.monotonic() + 20.0
        lines = []
        while time.monotonic() < deadline:
            line = process.stdout.readline()
            lines.append(line)
            if "tracker ready" in line:
                break
        assert "tracker ready" in lines[-1], lines
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=2.0) == 0
    finally:
        if process.poll() is None:
            process.kill()
    bad = subprocess.run(
        [str(EXECUTABLE), "--ros-args", "-p", "filter:=alpha_beta", "-p", "alpha:=1.5"],
        env=env,
        capture_output=True,
        text=True,
        timeout=20,
    )
    assert bad.returncode == 2 and "alpha" in bad.stderr


def test_track_messages_carry_every_field_of_the_track_set():
    import numpy as np
    from std_msgs.msg import Header

    from tracker_filter.tracker_node import track_to_msg, tracks_to_msg
    from tracker_filter.tracking import TrackSet

    rng = np.random.default_rng(67)
    count, layout = 3, ("x", "y", "w", "h")  # a layout without velocity
    covariances = rng.normal(size=(count, 4, 4))
    tracks = TrackSet(
        time=2.0,
        state_layout=layout,
        ids=np.array([7, 9, 12]),
        status=np.array([0, 1, 2]),
        means=rng.normal(size=(count, 4)) * 100,
        covariances=covariances,
        bboxes=np.array([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, -1.0, 8.0], [0.5, 0.5, 9.0, 0.0]]),
        ages=np.array([0.0, 1.5, 3.25]),
        hits=np.array([1, 4, 9]),
        misses=np.array([0, 0, 2]),
        existence=np.array([1.0, 0.5, 0.25]),
        areas=np.zeros(count),
        detections=np.array([0, 1, -1]),
    )
    msg = tracks_to_msg(tracks, Header(frame_id="scene"))
    assert msg.header.frame_id == "scene" and len(msg.tracks) == count
    for i, (track, report) in enumerate(zip(msg.tracks, tracks, strict=True)):
        assert track == track_to_msg(tracks, i)
        assert (track.id, track.status) == (report.id, int(report.status))
        assert (track.x, track.y) == tuple(report.position)
        assert (track.vx, track.vy) == (0.0, 0.0)
        assert list(track.position_covariance) == list(report.position_covariance.reshape(-1))
        assert track.state_layout == "x y w h"
        assert list(track.state) == list(report.mean)
        assert list(track.covariance) == list(report.covariance.reshape(-1))
        box = (track.bbox.x, track.bbox.y, track.bbox.width, track.bbox.height)
        assert box == tuple(max(v, 0.0) if k >= 2 else v for k, v in enumerate(report.bbox))
        assert (track.existence, track.age) == (report.existence, report.age)
        assert (track.hits, track.consecutive_misses) == (report.hits, report.consecutive_misses)
    # no tracks: ids, status, means, covariances, bboxes, ages, hits, misses, existence, ...
    shapes = ((), (), (4,), (4, 4), (4,), (), (), (), (), (), ())
    empty = TrackSet(0.0, layout, *(np.zeros((0,) + shape) for shape in shapes))
    assert tracks_to_msg(empty, Header()).tracks == []


BLOB_FIELDS = [
    Field("blobs[*].centroid_x"),
    Field("blobs[*].centroid_y"),
    Field("blobs[*].bbox.x"),
    Field("blobs[*].bbox.y"),
    Field("blobs[*].bbox.width", positive=True),
    Field("blobs[*].bbox.height", positive=True),
    Field("blobs[*].score"),
    Field("blobs[*].angle"),
    Field("blobs[*].oriented_width", positive=True),
    Field("blobs[*].oriented_height", positive=True),
]
WINDOW_FIELDS = [
    Field("window.x"),
    Field("window.y"),
    Field("window.width", positive=True),
    Field("window.height", positive=True),
]
NS = 100_000_000


def people_at(stamp_ns, k):
    """Frame k: two people walking towards each other (they cross at frame 10)."""
    msg = BlobArray(target_present=True)
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = "scene"
    for x in (100.0 + 8.0 * k, 260.0 - 8.0 * k):
        y = 150.0 + (x - 100.0) * 0.1
        blob = Blob(centroid_x=x, centroid_y=y, area=1200, label="person", score=0.8)
        blob.bbox.x, blob.bbox.y, blob.bbox.width, blob.bbox.height = x - 10, y - 30, 20.0, 60.0
        msg.blobs.append(blob)
    return msg


def view_at(stamp_ns, k=0):
    state = PtzState(zoom=1.0, focal_length=440.0)
    state.header.stamp = ns_to_stamp(stamp_ns)
    state.window.x, state.window.y, state.window.width, state.window.height = (
        40.0 + 2 * k,
        60.0,
        264.0,
        198.0,
    )
    return state


def test_hundreds_of_hostile_messages_change_no_good_answer(capfd):
    """Seeded: 20 frames of two people crossing, and after each 15 hostile detections (one field
    of every blob non-finite, huge or a negative size) or pan-tilt states (a window field), stamped
    between frames, far ahead, back in time, on the last frame, the next frame's or before zero.
    The tracks and targets of the good frames are the clean run's, the node lives, and each cause
    is logged once."""
    rng = np.random.default_rng(67)
    sources = [
        HostileSource("detections", lambda ns: people_at(ns, 3), BLOB_FIELDS),
        HostileSource("ptz/state", view_at, WINDOW_FIELDS),
    ]

    def run(hostile: bool):
        h = NodeHarness(
            TrackerNode,
            inputs={"detections": (BlobArray, 50), "ptz/state": (PtzState, 50)},
            outputs={"target": (Target, 50)},
        )
        tracks = record_publishes(h.node._tracks_pub)
        targets = record_publishes(h.node._target_pub)
        try:
            answers = []
            for k in range(20):
                stamp = k * NS
                h.feed("ptz/state", view_at(stamp, k))
                h.feed("detections", people_at(stamp, k))
                assert tracks[-1].header.stamp == targets[-1].header.stamp == ns_to_stamp(stamp)
                answers.append((track_values(tracks[-1]), target_values(targets[-1])))
                if hostile:
                    feed_hostile(h, rng, sources, stamp, NS)
            return answers, dict(h.node.problems.counts)
        finally:
            h.close()

    clean = assert_unchanged_by_hostile_messages(run, capfd, counted_at_least=250)
    assert any(target[0] for _, target in clean)


def track_values(msg):
    return [(t.id, t.x, t.y, t.vx, t.vy, t.bbox.width, t.bbox.height) for t in msg.tracks]


def target_values(msg):
    track = msg.track
    return (msg.locked, track.id, track.x, track.y, msg.predicted_x, msg.predicted_y)
