"""The demo's recording and report: bag round trip, summary figures, MOT file, annotated video."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

pytestmark = pytest.mark.ros

FRAMES = 6
MS = 1_000_000


def _messages(k: int):
    from tracker_msgs.msg import Blob, BlobArray, PtzCommand, PtzState, Target, Track, TrackArray
    from tracker_msgs_py.codec import array_to_image, ns_to_stamp, rect_to_msg
    from tracker_msgs_py.geometry import Rect

    stamp = ns_to_stamp(k * 100 * MS)  # frame k of a 10 fps recording
    scene = np.full((60, 80, 3), 40 + 10 * k, np.uint8)
    view = scene[10:40, 20:50].copy()
    state = PtzState(
        pan=0.0, tilt=0.0, zoom=1.0, focal_length=100.0, window=rect_to_msg(Rect(20, 10, 30, 30))
    )
    state.header.stamp = stamp
    blobs = BlobArray(
        blobs=[
            Blob(centroid_x=30.0, centroid_y=20.0, bbox=rect_to_msg(Rect(28, 18, 4, 4)), area=16)
        ]
    )
    blobs.header.stamp = stamp
    track = Track(
        id=7,
        status=Track.STATUS_CONFIRMED if k >= 2 else Track.STATUS_TENTATIVE,
        x=35.0 + k,
        y=25.0,
        bbox=rect_to_msg(Rect(33 + k, 23, 4, 4)),
        existence=1.0,
    )
    coasting = Track(  # a prediction, not an observation: drawn dashed, not written to MOT
        id=8, status=Track.STATUS_COASTING, x=10.0, y=10.0, bbox=rect_to_msg(Rect(8, 8, 4, 4))
    )
    tracks = TrackArray(tracks=[track, coasting] if k >= 4 else [track])
    tracks.header.stamp = stamp
    target = Target(locked=k >= 2, track=track, predicted_x=36.0 + k, predicted_y=25.0)
    target.header.stamp = stamp
    command = PtzCommand(mode=PtzCommand.MODE_HOLD)
    command.header.stamp = stamp
    return stamp, [
        ("/scene/image_raw", 0, array_to_image(scene, "bgr8", stamp, "scene")),
        ("/camera/image_raw", 2, array_to_image(view, "bgr8", stamp, "cam")),
        ("/ptz/state", 3, state),
        ("/detections", 6, blobs),
        ("/tracks", 8, tracks),
        ("/target", 8, target),
        ("/ptz/command", 9, command),
    ]


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    from rclpy.serialization import serialize_message

    from tracker_ptz_sim.bringup.graph import load_graph
    from tracker_ptz_sim.evaluation.recording import BagWriter

    path = tmp_path_factory.mktemp("run") / "bag"
    writer = BagWriter(path, {t.name: t.type for t in load_graph().topics})
    for k in range(FRAMES):
        _, messages = _messages(k)
        for topic, offset_ms, msg in messages:
            writer.write(topic, (k * 50 + offset_ms) * MS, serialize_message(msg))
    writer.close()
    return path


def test_bag_round_trips_every_type(bag):
    from tracker_ptz_sim.evaluation.recording import read_bag, topic_counts

    counts = topic_counts(bag)
    assert counts["/scene/image_raw"] == FRAMES and counts["/target"] == FRAMES
    targets = [msg for topic, _, msg in read_bag(bag, {"/target"})]
    assert [t.locked for t in targets] == [k >= 2 for k in range(FRAMES)]
    assert targets[3].track.id == 7 and targets[3].predicted_x == 39.0
    assert list(read_bag(bag, {"/diagnostics"})) == []  # a topic the bag lacks: no message


def test_images_recorded_as_jpeg_are_read_under_their_raw_names(tmp_path):
    """The recorder's default: Image topics go into the bag as JPEG CompressedImages on
    `<topic>/compressed`; readers asking for the raw name get them, decoded to the same picture."""
    from rclpy.serialization import serialize_message

    from tracker_msgs_py.codec import decode_image
    from tracker_ptz_sim.bringup.graph import load_graph
    from tracker_ptz_sim.evaluation.recording import BagWriter, jpeg_cdr, read_bag, recorded_topics

    topics = recorded_topics({t.name: t.type for t in load_graph().topics})
    assert topics["/scene/image_raw/compressed"] == "sensor_msgs/msg/CompressedImage"
    assert "/scene/image_raw" not in topics and topics["/target"] == "tracker_msgs/msg/Target"
    writer = BagWriter(tmp_path / "bag", topics)
    _, messages = _messages(3)
    (_, _, scene), (_, _, view) = messages[:2]
    writer.write("/scene/image_raw/compressed", 1, jpeg_cdr(serialize_message(scene)))
    writer.write("/camera/image_raw/compressed", 2, jpeg_cdr(serialize_message(view)))
    writer.close()
    read = {topic: msg for topic, _, msg in read_bag(tmp_path / "bag", {"/scene/image_raw"})}
    assert set(read) == {"/scene/image_raw"}  # the camera's were not asked for
    pixels = decode_image(read["/scene/image_raw"])
    assert pixels.shape == (scene.height, scene.width, 3)
    assert read["/scene/image_raw"].header.stamp.nanosec == scene.header.stamp.nanosec
    original = decode_image(scene).astype(int)
    assert abs(pixels.astype(int) - original).mean() < 4  # JPEG, close to the original


def test_summary_figures(bag):
    from tracker_ptz_sim.evaluation import run_report

    frames = run_report.collect(bag)
    summary = run_report.summarize(frames, run_report.message_counts(frames))
    assert summary.frames == FRAMES
    assert summary.throughput_fps == pytest.approx(20.0)  # scene images received every 50 ms
    assert summary.latency_ms["video_source -> ptz_camera"]["p50"] == pytest.approx(2.0)
    assert summary.latency_ms["camera image -> command"]["p95"] == pytest.approx(7.0)
    assert summary.latency_ms["camera image -> command"]["min"] == pytest.approx(7.0)
    assert summary.locked_share == pytest.approx(4 / 6)
    # The target is at x = 35 + k, y = 25 against the view centre (35, 25): distances 2, 3, 4, 5.
    assert summary.mean_center_distance_px == pytest.approx(3.5)
    assert summary.mean_center_distance_share == pytest.approx(3.5 / 30)
    assert summary.tracks_seen == 2  # the observed track and the coasting one
    assert run_report.stream_fps(frames) == pytest.approx(10.0)
    assert "throughput" in run_report.format_summary(summary)


def test_mot_file_lists_observed_confirmed_tracks_only(bag, tmp_path):
    from tracker_ptz_sim.evaluation import run_report

    frames = run_report.collect(bag)
    path = tmp_path / "tracks.txt"
    assert run_report.write_mot(frames, path) == FRAMES - 2
    rows = [line.split(",") for line in path.read_text().splitlines()]
    assert [int(r[0]) for r in rows] == [3, 4, 5, 6]
    assert {int(r[1]) for r in rows} == {7}
    assert [float(r[2]) for r in rows] == [35.0, 36.0, 37.0, 38.0]


def test_annotated_video_has_every_frame(bag, tmp_path):
    from tracker_ptz_sim.evaluation import run_report

    frames = run_report.collect(bag)
    path = tmp_path / "annotated.mp4"
    assert run_report.render_video(bag, frames, path, 10.0) == FRAMES
    capture = cv2.VideoCapture(str(path))
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == FRAMES
    ok, image = capture.read()
    assert ok and image.shape[1] > 80  # scene plus the camera view beside it
    summary = run_report.summarize(frames, {})
    run_report.write_summary(summary, tmp_path / "summary.json")
    assert json.loads((tmp_path / "summary.json").read_text())["frames"] == FRAMES


def test_graph_description_is_consistent():
    from tracker_ptz_sim.bringup.graph import format_value, load_graph, node_parameters, ros_args

    graph = load_graph()
    names = [n.name for n in graph.nodes]
    assert names == ["video_source", "ptz_camera", "ssim_detector", "tracker", "ptz_controller"]
    assert [p.name for p in graph.params_files] == ["surveillance.yaml", "person.yaml"]
    for name in names:
        assert node_parameters(graph.params_files, name).get("use_sim_time") is True
    args = ros_args(
        graph.node("tracker"), graph.params_files, {"lead_time": 0.2, "flag": False, "topic": ""}
    )
    assert args[:5] == [
        "--ros-args",
        "-r",
        "__node:=tracker",
        "--params-file",
        str(graph.params_files[0]),
    ]
    assert "tracker:lead_time:=0.2" in args and "tracker:flag:=false" in args
    assert 'tracker:topic:=""' in args
    assert format_value([1.0, 2.0]) == "[1.0,2.0]"


def test_set_arguments_read_back_as_the_values_given():
    from tracker_ptz_sim.bringup.graph import override_arguments, parse_overrides

    given = ["video_source.recorder_topic=", "tracker.lead_time=0.2", "tracker.topic=a/b"]
    overrides = parse_overrides(given)
    # nothing after the '=' is an empty string (a topic turned off), never the text "None"
    assert overrides == {
        "video_source": {"recorder_topic": ""},
        "tracker": {"lead_time": 0.2, "topic": "a/b"},
    }
    assert (
        parse_overrides(a.removeprefix("--set=") for a in override_arguments(overrides))
        == overrides
    )


def test_set_arguments_take_the_ros_launch_spelling_and_refuse_malformed_names():
    from tracker_ptz_sim.bringup.graph import parse_overrides

    assert parse_overrides(["tracker.lead_time:=0.2"]) == {"tracker": {"lead_time": 0.2}}
    assert parse_overrides(["tracker.qos.depth=5"]) == {"tracker": {"qos.depth": 5}}
    for item in ["tracker.lead time=1", "tracker.=1", "tracker.lead_time::=1", "2d.x=1"]:
        with pytest.raises(SystemExit, match="not a node name and a parameter name"):
            parse_overrides([item])
    with pytest.raises(SystemExit, match="expects node.param=value"):
        parse_overrides(["tracker.lead_time"])


def test_a_set_argument_for_a_node_the_graph_lacks_is_refused_by_name(capsys):
    from tracker_ptz_sim.bringup import benchmark
    from tracker_ptz_sim.bringup.graph import load_graph, unknown_override_nodes

    graph = load_graph("surveillance")
    assert unknown_override_nodes({"ssim_detector": {"min_aspect": 0.5}}, [graph]) is None
    problem = unknown_override_nodes({"detector": {"min_aspect": 0.5}}, [graph])
    assert problem is not None and "no node detector" in problem and "ssim_detector" in problem
    # the small-objects graph names its detector `detector`: fine when that graph runs too
    both = [graph, load_graph("small_objects")]
    assert unknown_override_nodes({"detector": {"history": 50}}, both) is None
    with pytest.raises(SystemExit):
        benchmark.main(["--scenes", "walkers", "--configs", "suite", "--set", "detector.x=1"])
    assert "no node detector" in capsys.readouterr().err


def test_colour_graph_hands_motion_over_to_camshift_on_its_own_topics():
    from tracker_ptz_sim.bringup.graph import load_graph, node_parameters

    graph = load_graph("colour")
    assert [p.name for p in graph.params_files] == [
        "surveillance.yaml",
        "motion.yaml",
        "colour.yaml",
    ]
    detector = node_parameters(graph.params_files, "colour_detector")
    assert detector["method"] == "camshift" and detector["lockstep_targets"] is True
    assert node_parameters(graph.params_files, "ssim_detector")["method"] == "ssim_background"
    assert node_parameters(graph.params_files, "colour_tracker")["filter"] == "robust_kalman"
    motion = graph.node("tracker").remappings
    assert motion == {
        "detections": "motion/detections",
        "tracks": "motion/tracks",
        "target": "motion/target",
    }
    assert graph.node("ssim_detector").remappings == {"detections": "motion/detections"}
    assert graph.node("colour_detector").remappings == {"handover_target": "motion/target"}
    recorded = {t.name for t in graph.topics}
    assert {"/motion/target", "/motion/tracks", "/target", "/tracks"} <= recorded
    assert set(graph.ready) <= recorded


def _launch_actions(monkeypatch, **arguments) -> tuple[list, list]:
    """The launch file's entities (("arg", name, default), ("env", name, value)) and the nodes it
    creates for `arguments` (each a dict of launch_ros.actions.Node's arguments), read with
    run_launch's implementation of the launch API (`launch` / `launch_ros` are not on PyPI)."""
    from dataclasses import asdict
    from pathlib import Path

    from tracker_ptz_sim.bringup.launch_runner import (
        DeclareLaunchArgument,
        load_description,
        resolve,
    )

    path = Path(__file__).resolve().parents[2] / "src/tracker_ptz_sim/launch/surveillance.launch.py"
    description = load_description(path)
    plan = resolve(description, arguments)
    declared = [e for e in description.entities if isinstance(e, DeclareLaunchArgument)]
    entities = [("arg", e.name, e.default_value) for e in declared]
    entities += [("env", name, value) for name, value in plan.environment.items()]
    return entities, [asdict(node) for node in plan.nodes]


def test_launch_file_builds_the_same_graph(monkeypatch):
    """The launch file (for real installs) starts exactly the graph's nodes with its parameters,
    every node with the namespace given (tests/demo/test_launch_resolution.py: how rcl resolves
    them)."""
    entities, created = _launch_actions(monkeypatch, video="/data/v.avi", respawn="true")
    assert ("arg", "video", "") in entities and ("arg", "camera", "sim") in entities
    assert [n["name"] for n in created] == [
        "video_source",
        "ptz_camera",
        "ssim_detector",
        "tracker",
        "ptz_controller",
        "ptz_tf",  # the unit's TF tree (tf:=auto: robot_state_publisher where installed)
    ]
    source = created[0]
    assert source["parameters"][0].endswith("surveillance.yaml")
    assert source["parameters"][-1]["path"] == "/data/v.avi"
    assert all(n["namespace"] == "" for n in created)
    assert ("arg", "respawn", "false") in entities and source["respawn"] is False
    assert all(n["respawn"] is True and n["respawn_max_retries"] == 5 for n in created[1:])


def test_launch_file_runs_the_colour_graph_on_request(monkeypatch):
    _, created = _launch_actions(monkeypatch, video="v.avi", graph="colour")
    names = [n["name"] for n in created]
    assert "colour_detector" in names and "colour_tracker" in names
    detector = created[names.index("colour_detector")]
    assert [p.rsplit("/", 1)[-1] for p in detector["parameters"][:3]] == [
        "surveillance.yaml",
        "motion.yaml",
        "colour.yaml",
    ]
    assert ("handover_target", "motion/target") in detector["remappings"]


def test_launch_file_adds_the_live_view_on_request(monkeypatch):
    _, created = _launch_actions(monkeypatch, video="v.avi", live_view="true")
    (live,) = [n for n in created if n["name"] == "live_view"]
    assert live["executable"] == "live_view"


def test_launch_file_pipelines_the_replay_on_request(monkeypatch):
    entities, created = _launch_actions(monkeypatch, video="v.avi", frames_in_flight="2")
    assert ("arg", "frames_in_flight", "1") in entities
    by_name = {n["name"]: n for n in created}
    assert by_name["video_source"]["parameters"][-1]["frames_in_flight"] == 2
    assert by_name["ptz_camera"]["parameters"][-1]["command_delay_frames"] == 2
    with pytest.raises(ValueError, match="frames_in_flight must be a whole number, got 'two'"):
        _launch_actions(monkeypatch, video="v.avi", frames_in_flight="two")


def test_launch_file_runs_behind_a_live_camera_under_a_namespace(monkeypatch):
    _, created = _launch_actions(monkeypatch, camera="live", namespace="cam1")
    assert [n["name"] for n in created][0] == "ptz_state_bridge"
    assert all(n["namespace"] == "cam1" for n in created)
    assert created[0]["parameters"][-2].endswith("live.yaml")


def test_the_malloc_setting_is_the_same_for_shells_runner_and_launch(monkeypatch):
    from pathlib import Path

    from tracker_ptz_sim.bringup.graph import MALLOC_TUNABLES

    env_sh = (Path(__file__).resolve().parents[2] / "scripts/env.sh").read_text()
    assert f'GLIBC_TUNABLES="${{GLIBC_TUNABLES:-{MALLOC_TUNABLES}}}"' in env_sh
    monkeypatch.delenv("GLIBC_TUNABLES", raising=False)
    entities, _ = _launch_actions(monkeypatch, video="v.avi")
    assert ("env", "GLIBC_TUNABLES", MALLOC_TUNABLES) in entities


def test_a_restarted_source_resumes_after_the_frames_whose_statuses_were_lost():
    """The killed source's last status says frame 63 (6.3 s), but the recorder got the scene
    images up to 6.6 s: those went out too (the camera may have rendered them), so the new
    source starts at frame 67, not 64."""
    from tracker_msgs.msg import ReplayStatus
    from tracker_msgs_py.codec import ns_to_stamp
    from tracker_ptz_sim.bringup.demo import resume_frame

    status = ReplayStatus(frame_index=63, frames_published=64)
    status.header.stamp = ns_to_stamp(6_300_000_000)
    recorded = [k * 100_000_000 for k in range(60, 67)]  # 6.0 ... 6.6 s
    assert resume_frame(status, recorded) == 67
    assert resume_frame(status, recorded[:4]) == 64  # nothing recorded beyond the status


def test_the_recorder_writes_at_a_lower_priority_than_the_graph():
    """Its JPEG encoding must not take a core from the node a lockstep frame waits for."""
    import os
    import threading

    from tracker_ptz_sim.bringup.demo import WRITER_NICENESS, _lower_priority

    seen = []

    def writer() -> None:
        _lower_priority(WRITER_NICENESS)
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))

    thread = threading.Thread(target=writer)
    thread.start()
    thread.join()
    assert WRITER_NICENESS > 0 and seen == [
        min(os.getpriority(os.PRIO_PROCESS, 0) + WRITER_NICENESS, 19)
    ]
    assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == os.getpriority(
        os.PRIO_PROCESS, 0
    )  # the calling thread keeps its own


def test_the_nodes_warnings_are_collected_from_their_logs(tmp_path):
    from tracker_ptz_sim.bringup.demo import node_warnings

    (tmp_path / "tracker.log").write_text(
        "[INFO] [1795998000.934146527] [tracker]: tracker ready\n"
        "[WARN] [1795998000.937324377] [tracker]: ignored parameter(s) lead_tme: ...\n"
        "[WARN] [1795998001.000000000] [tracker]: ignored parameter(s) lead_tme: ...\n"
        "Traceback (most recent call last):\n"
    )
    (tmp_path / "video_source.log").write_text(
        "[ERROR] [1795997803.195329155] [video_source]: replay of x failed: no frame\n"
    )
    (tmp_path / "ptz_controller.log").write_text(
        "[FATAL] pan_limits must hold finite numbers, got [nan, 1.0]\n"  # a node that cannot start
    )
    assert node_warnings(tmp_path) == [
        "ptz_controller: pan_limits must hold finite numbers, got [nan, 1.0]",
        "tracker: ignored parameter(s) lead_tme: ...",
        "video_source: replay of x failed: no frame",
    ]
    assert node_warnings(tmp_path, limit=1) == [
        "ptz_controller: pan_limits must hold finite numbers, got [nan, 1.0]"
    ]
