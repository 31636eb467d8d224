"""run_demo: the whole surveillance graph as separate processes, recorded and summarised.

    run_demo [--video PATH] [--out out] [--graph surveillance|colour|standard|small_objects]
             [--mode servo|direct|hold] [--set node.param=value ...] [--respawn] [--no-video] [--live]

Starts every node of the graph (config/graph.yaml; --graph colour: config/colour_graph.yaml;
--graph standard: config/standard_graph.yaml; --graph small_objects:
config/small_objects_graph.yaml, a fixed camera tracking many small movers)
from the install space (exactly as `ros2 run` would) with its parameter files, replays the video
in lockstep, records every topic into an MCAP bag with `rosbags`, shows progress, and writes to
the output directory:
    bag/            rosbag2 (MCAP) of every topic, images as JPEG on <topic>/compressed
                    (--raw-images: as they travel)
    annotated.mp4   scene with camera window, blobs, tracks, target; camera view beside it
    contact_sheet.png  the followed target every 2 s, cropped from the scene
    tracks.txt      confirmed tracks, MOTChallenge format
    summary.json    frames, throughput, per-hop latency, lock share, centring error (also
                    printed), and the run's account: complete or not, and why; the camera
                    image -> command latency timed by ptz_camera itself (run.camera_latency_ms)
    logs/           one log per node

A node that dies is reported with its last log lines; with --respawn it is restarted (video_source
resumes at the next frame), otherwise the run ends. Either way, and on Ctrl-C, whatever was
recorded is summarised and written, and the summary says the run is incomplete (exit code 1, or
130 when interrupted).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import queue
import re
import shutil
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import Enum
from functools import partial
from pathlib import Path
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.subscription import Subscription
from std_msgs.msg import Header

from tracker_msgs.msg import ReplayStatus
from tracker_msgs_py import stop_signals
from tracker_msgs_py.codec import (
    command_qos,
    header_stamp_ns,
    is_command_topic,
    ns_to_stamp,
    result_qos,
    stamp_to_ns,
)
from tracker_msgs_py.node_main import (
    DEFAULT_EXECUTOR,
    EXECUTORS,
    CallbackLoad,
    callback_load,
    matched_readers,
    matched_writers,
)
from tracker_msgs_py.params import config_from_params
from tracker_ptz_sim.bringup.graph import (
    GRAPHS,
    LIVE_VIEW,
    Graph,
    TopicSpec,
    load_graph,
    missing_topics,
    node_parameters,
    parse_overrides,
    pipelined,
    unknown_override_nodes,
    with_live_view,
    without_nodes,
)
from tracker_ptz_sim.bringup.processes import HOST, GraphProcesses, describe_exit
from tracker_ptz_sim.evaluation import run_report
from tracker_ptz_sim.evaluation.contact_sheet import write_contact_sheet
from tracker_ptz_sim.evaluation.recording import (
    COMPRESSED,
    RAW_IMAGE,
    BagWriter,
    jpeg_cdr,
    recorded_topics,
)
from tracker_ptz_sim.simulation.camera_model import (
    MAX_COMMAND_DELAY_FRAMES,
    PtzCameraModel,
    PtzConfig,
)
from tracker_ptz_sim.simulation.command_latency import from_diagnostics
from tracker_ptz_sim.simulation.live_stream import is_live_stream, open_input, redacted
from tracker_ptz_sim.simulation.video_source_node import STATUS_QOS

SCENE_TOPIC = "/scene/image_raw"
VideoInput = Path | str  # a recording's path, or a live stream's URL

#: What a lockstep video_source sends once more when a frame's acknowledgement is late (its
#: `_wait_for_ack`); the recorder keeps the first of each stamp, as every node does.
REPEATED_TOPICS = frozenset({SCENE_TOPIC, "/scene/camera_info"})
#: The recorder says here which scene images it has received (std_msgs/Header with the image's
#: stamp); a lockstep video_source waits for it too (its `recorder_topic`).
RECORDED_TOPIC = "/replay/recorded"
MATCH_TIMEOUT_S = 10.0  # longest the replay waits for the publishers to match their readers
STATUS_QUIET_S = 0.3  # no replay status for this long: a killed source's last ones have arrived
RECORDING_QUIET_S = 0.5  # nothing recorded for this long after the end: the last messages are in
RESPAWN_LIMIT = 5  # --respawn: restarts per node before the run gives up on it

#: What the suite's nodes publish with `codec.result_qos` (transient local): the recorder asks for
#: their history, so a result published before its writer had discovered the recorder (the first
#: frames, on a loaded machine) still reaches the bag. Images and clock come without history, and
#: commands (`codec.is_command_topic`, e.g. JointState on ptz/joint_command) volatile.
RESULT_TYPES = frozenset(
    {
        "tracker_msgs/msg/BlobArray",
        "tracker_msgs/msg/TrackArray",
        "tracker_msgs/msg/Target",
        "tracker_msgs/msg/PtzState",
        "sensor_msgs/msg/JointState",
    }
)
CLOCK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=50, reliability=ReliabilityPolicy.BEST_EFFORT
)


# The recorder's writer encodes and writes this many nice levels below the graph: on a machine
# with few cores its JPEG encoding otherwise takes a core from the node the frame waits for (2 cores,
# 3 runs each way: 65-67 -> 68-74 frames/s, image -> command p95 16.3-17.5 -> 15.1-16.9 ms).
# It still gets the cores whenever the lockstep's chain leaves one idle; pipelined with 3
# frames in flight (both cores busy) its queue held at most 72 messages (~7 frames).
WRITER_NICENESS = 10


def _lower_priority(by: int) -> None:
    """Run the calling thread `by` nice levels lower (Linux: per thread); elsewhere leave it."""
    with contextlib.suppress(AttributeError, OSError):
        thread = threading.get_native_id()
        os.setpriority(
            os.PRIO_PROCESS, thread, min(os.getpriority(os.PRIO_PROCESS, thread) + by, 19)
        )


class RepeatFilter:
    """Which messages repeat one already taken: the same stamp again on a topic of `topics`,
    among the last `memory` stamps there."""

    def __init__(self, topics: Iterable[str], memory: int) -> None:
        self._seen: dict[str, deque[int]] = {topic: deque(maxlen=memory) for topic in topics}

    def repeats(self, topic: str, stamp_ns: int) -> bool:
        """Whether `stamp_ns` was taken on `topic` before; if not, it is now."""
        seen = self._seen.get(topic)
        if seen is None:
            return False
        if stamp_ns in seen:
            return True
        seen.append(stamp_ns)
        return False

    def taken(self, topic: str) -> tuple[int, ...]:
        """The newest stamps taken on `topic`, oldest first."""
        return tuple(self._seen.get(topic, ()))


class Recorder(Node):
    """Records the graph's topics (serialized, as received; images as JPEG on `<topic>/compressed`
    unless `raw_images`) and follows the replay's progress.

    A subscription callback only queues what arrived; a writer thread encodes and writes it. A
    recorder that encoded in its callbacks fell seconds behind on a loaded machine, and the
    readers' histories (200 results, 30 images) then overflowed: a run lost half its scene
    images with nothing said. `close()` writes what is queued and stops the writer."""

    def __init__(
        self, graph: Graph, bag: BagWriter, raw_images: bool = False, context: Any = None
    ) -> None:
        super().__init__("run_recorder", context=context)
        self.bag = bag
        self.status: ReplayStatus | None = None
        self.status_received = time.monotonic()
        self.received_at = time.monotonic()  # when the last message to record arrived
        self.received: Counter[str] = Counter()  # messages to record, per graph topic
        self.write_error: Exception | None = None  # the first message the bag could not take
        self._pending: queue.SimpleQueue[tuple[str, int, bytes, bool] | None] = queue.SimpleQueue()
        self._writer = threading.Thread(target=self._write, name="recorder.writer", daemon=True)
        self._writer.start()
        self._keep: dict[str, Subscription] = {}  # per graph topic, the recorder's subscription
        for topic in graph.topics:
            msg_type = import_message_type(topic.type)
            qos = CLOCK_QOS if topic.name == "/clock" else self._qos_for(topic)
            self._keep[topic.name] = self.create_subscription(
                msg_type,
                topic.name,
                partial(self._record_jpeg, topic.name + COMPRESSED)
                if topic.type == RAW_IMAGE and not raw_images
                else partial(self._record, topic.name),
                qos,
                raw=True,
                event_callbacks=SubscriptionEventCallbacks(
                    incompatible_qos=partial(self._incompatible, topic.name)
                ),
            )
        self.create_subscription(ReplayStatus, "/replay/status", self._on_status, STATUS_QOS)
        # the newest stamps of the scene images (a restarted source resumes after them)
        self._repeats = RepeatFilter(REPEATED_TOPICS, MAX_COMMAND_DELAY_FRAMES + 2)
        self._recorded_pub = self.create_publisher(Header, RECORDED_TOPIC, 10)
        self.readers: dict[str, int] = {}  # per topic, the readers its publisher has matched
        self.writers: dict[str, dict[str, int]] = {}  # per node and topic, its reader's writers
        # the camera's own image-to-command latency, from its latest diagnostics
        self.camera_latency: dict[str, float] = {}
        self.callback_load: dict[str, CallbackLoad] = {}  # by node, from its latest diagnostics
        self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 50)

    @staticmethod
    def _qos_for(topic: TopicSpec) -> QoSProfile:
        """The QoS the topic's publishers offer: commands volatile, results with their history,
        images without."""
        if is_command_topic(topic.name):
            return command_qos()
        return result_qos(late_joiners=topic.type in RESULT_TYPES)

    def _incompatible(self, topic: str, _event: object) -> None:
        self.get_logger().error(
            f"{topic} is not recorded: its publisher's QoS cannot match the recorder's (a result "
            "must be published with tracker_msgs_py.codec.result_qos, which keeps a history, a "
            "command with codec.command_qos)",
            once=True,
        )

    def _record(self, topic: str, data: bytes) -> None:
        self._take(topic, data, jpeg=False)

    def _record_jpeg(self, topic: str, data: bytes) -> None:
        self._take(topic, data, jpeg=True)

    @property
    def scene_stamps(self) -> tuple[int, ...]:
        """The newest scene images' stamps recorded, oldest first."""
        return self._repeats.taken(SCENE_TOPIC)

    def _take(self, topic: str, data: bytes, jpeg: bool) -> None:
        """Queue a message for the bag (with its receive time) unless it repeats one taken, and
        acknowledge scene images, repeats too (the first acknowledgement may be what was late)."""
        graph_topic = topic.removesuffix(COMPRESSED)
        stamp = header_stamp_ns(data) if graph_topic in REPEATED_TOPICS else None
        if stamp is None or not self._repeats.repeats(graph_topic, stamp):
            self._pending.put((topic, time.time_ns(), data, jpeg))
            self.received[graph_topic] += 1
            self.received_at = time.monotonic()
        if graph_topic == SCENE_TOPIC and stamp is not None:
            self._recorded_pub.publish(Header(stamp=ns_to_stamp(stamp)))

    def _write(self) -> None:
        _lower_priority(WRITER_NICENESS)
        while (item := self._pending.get()) is not None:
            topic, received, data, jpeg = item
            try:
                self.bag.write(topic, received, jpeg_cdr(data) if jpeg else data)
            except Exception as error:  # one bad message must not end the recording
                self.write_error = self.write_error or error

    def close(self, timeout: float = 120.0) -> None:
        """Write what is still queued (up to `timeout` s) and stop the writer thread."""
        self._pending.put(None)
        self._writer.join(timeout)

    def wait_until_quiet(self, quiet: float = RECORDING_QUIET_S, limit: float = 10.0) -> None:
        """Until nothing arrived for `quiet` s (`limit` s at most): the last frames' messages
        are in, also when this process runs behind the graph."""
        started = time.monotonic()
        while time.monotonic() - started < limit and not stop_signals.requested():
            if time.monotonic() - max(self.received_at, started) >= quiet:
                return
            stop_signals.wait(0.05)

    def wait_for_camera_latency(self, frames: int, limit: float = 2.5) -> None:
        """Until the camera's diagnostics (once a second) have timed `frames` commands, `limit`
        s at most; at once when the camera reports none (a real unit's drivers)."""
        deadline = time.monotonic() + limit
        while (
            self.camera_latency
            and self.camera_latency.get("count", 0) < frames
            and time.monotonic() < deadline
            and not stop_signals.requested()
        ):
            stop_signals.wait(0.05)

    def _on_diagnostics(self, array: DiagnosticArray) -> None:
        self.readers.update(matched_readers(array))
        self.writers.update(matched_writers(array))
        self.callback_load.update(callback_load(array))
        for status in array.status:
            latency = from_diagnostics((v.key, v.value) for v in status.values)
            if latency:
                self.camera_latency = latency

    def readers_matched(self, topic: str) -> int:
        """The graph's readers of `topic` (this recorder's included) that have matched a writer."""
        nodes = sum(1 for topics in self.writers.values() if topics.get(topic, 0) > 0)
        own = self._keep.get(topic)
        return nodes + int(own is not None and own.get_publisher_count() > 0)

    def _on_status(self, status: ReplayStatus) -> None:
        self.status = status
        self.status_received = time.monotonic()

    def settled_status(
        self, quiet: float = STATUS_QUIET_S, timeout: float = 2.0
    ) -> ReplayStatus | None:
        """The replay status once none has arrived for `quiet` s (a killed video_source's last
        statuses may still be on their way), or after `timeout`."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and time.monotonic() - self.status_received < quiet:
            time.sleep(0.02)
        return self.status


def import_message_type(name: str) -> Any:
    """The message class of a type name such as "sensor_msgs/msg/Image"."""
    package, kind, message = name.split("/")
    module = __import__(f"{package}.{kind}", fromlist=[message])
    return getattr(module, message)


class Progress:
    """One updating line on a terminal, a line every 10 % otherwise."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.tty = sys.stdout.isatty()
        self.started = time.monotonic()
        self.last_decile = -1

    def show(self, done: int, total: int) -> None:
        rate = done / max(1e-9, time.monotonic() - self.started)
        text = f"{self.label}: {done}/{total or '?'} frames, {rate:.1f} frames/s"
        if self.tty:
            print("\r" + text, end="", flush=True)
        elif total:
            decile = 10 * done // total
            if decile != self.last_decile:
                self.last_decile = decile
                print(text, flush=True)

    def done(self) -> None:
        if self.tty:
            print(flush=True)


@dataclass
class RunResult:
    bag: Path
    exit_codes: dict[str, int] = field(default_factory=dict)  # by node, at the end of the run
    # by node, plus "recorder": CPU time during the replay (start-up left out, as in the
    # throughput)
    cpu_seconds: dict[str, float] = field(default_factory=dict)
    # by node ("/ssim_detector"): wall time in callbacks and messages received, at its last report
    callback_load: dict[str, CallbackLoad] = field(default_factory=dict)
    wall_seconds: float = 0.0  # from the first frame published to the end of the stream
    complete: bool = True  # the whole stream went through the graph
    problems: list[str] = field(default_factory=list)  # why not, and nodes that died
    restarts: dict[str, int] = field(default_factory=dict)  # by node (--respawn)
    interrupted_by: str | None = None  # "SIGINT" when the user stopped the run
    replay: dict[str, Any] = field(default_factory=dict)  # the last ReplayStatus
    # ptz_camera's own image-out -> command-in latency (ms: p50, p95, max; count)
    camera_latency: dict[str, float] = field(default_factory=dict)
    node_warnings: list[str] = field(default_factory=list)  # "node: message", from logs/

    def fail(self, problem: str) -> None:
        self.complete = False
        self.problems.append(problem)

    def as_dict(self) -> dict[str, Any]:
        """What summary.json says about the run itself."""
        return {
            "complete": self.complete,
            "problems": self.problems,
            "restarts": self.restarts,
            "interrupted_by": self.interrupted_by,
            "exit_codes": self.exit_codes,
            "replay": self.replay,
            "camera_latency_ms": self.camera_latency,
            "node_warnings": self.node_warnings,
        }


class Watch(Enum):
    RUNNING = "running"
    ENDED = "ended"  # video_source reached the end of the stream
    STOP = "stop"  # a node died and is not restarted


class Supervisor:
    """Watches the node processes: a node that ends is reported with its last log lines, then
    restarted (up to `respawn_limit` times, as launch's respawn does) or the run stops. A
    restarted video_source resumes at the frame after the last one it published."""

    def __init__(
        self,
        nodes: GraphProcesses,
        recorder: Recorder,
        result: RunResult,
        overrides: dict[str, dict[str, Any]],
        respawn_limit: int,
    ) -> None:
        self.nodes = nodes
        self.recorder = recorder
        self.result = result
        self.overrides = overrides
        self.respawn_limit = respawn_limit

    def check(self) -> Watch:
        for name, code in self.nodes.exited().items():
            if name in ("video_source", HOST) and code == 0 and self._stream_ended():
                return Watch.ENDED
            status = self.recorder.status
            frame = status.frames_published if status is not None else 0
            died = f"{name} {describe_exit(code)} after frame {frame}"
            print(f"[run_demo] {self.nodes.death_report(name, code)}", file=sys.stderr, flush=True)
            restarts = self.result.restarts.get(name, 0)
            if restarts >= self.respawn_limit:
                self.result.fail(f"{died} (see logs/{name}.log)")
                return Watch.STOP
            self.result.restarts[name] = restarts + 1
            self.result.problems.append(f"{died}; restarted")
            print(
                f"[run_demo] restarting {name} ({restarts + 1}/{self.respawn_limit})",
                file=sys.stderr,
                flush=True,
            )
            self.nodes.start(name, self._restart_overrides(name))
        return Watch.RUNNING

    def _stream_ended(self, quiet: float = 1.0, limit: float = 30.0) -> bool:
        """video_source exited 0: at the end of the stream, or stopped from outside? Its last
        status is waited for while statuses still arrive (a recorder behind on a loaded machine
        catches up): until none came for `quiet` s, `limit` s at most."""
        started = time.monotonic()
        while time.monotonic() - started < limit:
            status = self.recorder.status
            if status is not None and status.state != ReplayStatus.STATE_PLAYING:
                return bool(status.state == ReplayStatus.STATE_ENDED)
            if time.monotonic() - max(self.recorder.status_received, started) > quiet:
                return False
            time.sleep(0.05)
        return False

    def _restart_overrides(self, name: str) -> dict[str, Any]:
        overrides = dict(self.overrides.get(name, {}))
        if name != "video_source":
            return overrides
        status = self.recorder.settled_status()
        if status is not None and status.frames_published:
            overrides["start_frame"] = resume_frame(status, self.recorder.scene_stamps)
        return overrides


def resume_frame(status: ReplayStatus, scene_stamps: Iterable[int]) -> int:
    """Where a restarted video_source starts: after its last status's frame, and after every
    scene image recorded since (stamped later): the statuses of a killed source's last frames
    can be lost with it while their images got through (the camera rendered them)."""
    last = stamp_to_ns(status.header.stamp)
    return int(status.frame_index) + 1 + sum(1 for stamp in scene_stamps if stamp > last)


def stand_in_scene(
    graph: Graph, video: VideoInput, overrides: dict[str, dict[str, Any]]
) -> dict[str, dict[str, Any]]:
    """For a graph whose ptz_state_bridge listens to the simulated camera standing in for a real
    unit's drivers: the bridge's scene settings the simulator uses (the replayed scene's size, the
    camera's focal length in scene px/rad), so the bridge's ptz/state windows are the simulator's
    and runs score against the scene's ground truth. Values set in the files or overrides win."""
    if "ptz_state_bridge" not in {node.name for node in graph.nodes}:
        return {}
    bridge = {
        **node_parameters(graph.params_files, "ptz_state_bridge"),
        **overrides.get("ptz_state_bridge", {}),
    }
    if (
        bridge.get("scene_width")
        and bridge.get("scene_height")
        and bridge.get("scene_focal_length")
    ):
        return {}
    source = open_input(video)
    try:
        first = next(source.frames(0, 1))
    finally:
        source.close()
    height, width = first.image.shape[:2]
    camera = {
        **node_parameters(graph.params_files, "ptz_camera"),
        **overrides.get("ptz_camera", {}),
    }
    model = PtzCameraModel(config_from_params(PtzConfig, camera), width, height)
    derived = {
        "scene_width": width,
        "scene_height": height,
        "scene_focal_length": model.geometry.focal_length,
    }
    return {
        "ptz_state_bridge": {
            **{k: v for k, v in derived.items() if not bridge.get(k)},
            **overrides.get("ptz_state_bridge", {}),
        }
    }


def input_name(video: VideoInput) -> str:
    """How progress lines name the input: a recording's file name, a stream's URL (redacted)."""
    return redacted(str(video)) if is_live_stream(video) else Path(video).name


@dataclass(frozen=True)
class RunOptions:
    """How `run_graph` runs the graph and records it.

    `storage`: the bag's storage plugin ("mcap" or "sqlite3").
    `during(status, nodes)` is called while the replay runs (tests use it to kill and restart
    nodes); `respawn_limit` restarts per node (0: a node that dies ends the run).
    `shared_memory` (default: unless nodes may be killed or restarted, i.e. with `during` or
    `respawn_limit`) lets images travel through Fast DDS shared memory; a killed node can starve
    the other readers of it or stall its successor's shutdown (config/fastdds_udp.xml).
    `raw_images` records the images as they travel instead of as JPEG (a bag ~25x larger).
    `single_process` runs every node in one process on one executor (graph_host), which waits
    for the graph itself and ends at the end of the stream; no restarts. `executor` names the
    rclpy executor (`node_main.EXECUTORS`) of every node process (or of graph_host) and of the
    recorder.
    """

    storage: str = "mcap"
    during: Callable[[ReplayStatus | None, GraphProcesses], None] | None = None
    respawn_limit: int = 0
    shared_memory: bool | None = None
    raw_images: bool = False
    single_process: bool = False
    executor: str = DEFAULT_EXECUTOR


def run_graph(
    graph: Graph,
    video: VideoInput,
    out: Path,
    overrides: dict[str, dict[str, Any]],
    install_dir: Path,
    timeout: float,
    options: RunOptions = RunOptions(),
) -> RunResult:
    """Replay `video` through the graph, recording every topic into out/bag, run as `options`
    say (`RunOptions`).

    Never raises for a node that dies, a graph that does not come up, a timeout or a stop signal:
    the run ends, the bag is closed, and the result says why (`complete`, `problems`).
    """
    bag_path = out / "bag"
    for previous in (bag_path, out / "logs"):  # a run into the same out/ replaces the last one's
        if previous.exists():
            shutil.rmtree(previous)
    topics = recorded_topics({t.name: t.type for t in graph.topics}, options.raw_images)
    bag = BagWriter(bag_path, topics, options.storage)
    result = RunResult(bag_path)
    # Our stop signals, not rclpy's: the graph is stopped and the bag closed on Ctrl-C.
    rclpy.init(
        args=["--ros-args", "--disable-rosout-logs"],
        signal_handler_options=SignalHandlerOptions.NO,
    )
    recorder = Recorder(graph, bag, options.raw_images)
    # The recorder spins in its own thread: one executor for the whole run is far cheaper per
    # message than spin_once from the supervising loop below.
    recording = EXECUTORS[options.executor]()
    recording.add_node(recorder)
    recorded = threading.Event()  # set: the recorder's thread stops spinning
    spinner = threading.Thread(
        target=_spin_recorder, args=(recording, recorded, result), daemon=True
    )
    spinner.start()
    shared_memory = options.shared_memory
    if shared_memory is None:
        shared_memory = options.respawn_limit == 0 and options.during is None
    environment = {} if shared_memory else GraphProcesses.without_shared_memory(graph)
    nodes = GraphProcesses(graph, install_dir, out / "logs", environment, options.executor)
    live = any(node.name == LIVE_VIEW.name for node in graph.nodes)
    source_overrides = {
        "path": str(video),
        # The first frame goes out once every scene reader has matched: ptz_camera, this
        # recorder and the live view (counting 2 with the live view on let the source start
        # before the recorder matched: its bag lacked the first frames).
        "wait_for_subscribers": 3 if live else 2,
        # and each frame waits until this recorder has it: a loaded machine slows the replay
        # down instead of the bag losing frames
        "recorder_topic": RECORDED_TOPIC,
        **overrides.get("video_source", {}),
    }
    overrides = {**overrides, **stand_in_scene(graph, video, overrides)}
    supervisor = Supervisor(
        nodes,
        recorder,
        result,
        {**overrides, "video_source": source_overrides},
        options.respawn_limit,
    )
    try:
        if options.single_process:
            nodes.start_host({**overrides, "video_source": source_overrides}, live)
            _supervise(recorder, supervisor, timeout, options.during, nodes, input_name(video))
            return result
        for node in graph.nodes:
            if node.name != "video_source":
                nodes.start(node.name, overrides.get(node.name))
        if _wait_for_graph(graph, recorder, supervisor) and _wait_for_matches(graph, recorder):
            _replay(nodes, recorder, supervisor, source_overrides, timeout, options.during)
    finally:
        _stop_nodes(nodes, result)
        recorded.set()
        spinner.join(timeout=5.0)
        recording.shutdown()
        recorder.close()
        if recorder.write_error is not None:
            result.fail(f"the recorder could not write a message: {recorder.write_error!r}")
        recorder.destroy_node()
        rclpy.try_shutdown()
        bag.close()
        result.replay = _replay_summary(recorder.status)
        _check_recording(recorder, result)
        result.node_warnings = node_warnings(out / "logs")
    return result


# rclpy's "[WARN] [stamp] [node]: message", and node_main's "[FATAL] message" (a node that
# cannot start: its log file names the node)
LOGGED_PROBLEM = re.compile(
    r"^\[(?:WARN|ERROR|FATAL)\] (?:\[[0-9.]+\] \[(?P<node>[^\]]+)\]: )?(?P<message>.*)$"
)


def node_warnings(log_dir: Path, limit: int = 20) -> list[str]:
    """The warnings and errors the nodes logged, "node: message", each once, log by log, at most
    `limit` of them: what a user should see without opening logs/ (a parameter the node
    ignored, input it dropped, a peer whose QoS does not match)."""
    found: list[str] = []
    for log in sorted(log_dir.glob("*.log")):
        for line in log.read_text(errors="replace").splitlines():
            match = LOGGED_PROBLEM.match(line)
            warning = match and f"{match['node'] or log.stem}: {match['message']}"
            if warning and warning not in found:
                found.append(warning)
                if len(found) == limit:
                    return found
    return found


def _check_recording(recorder: Recorder, result: RunResult) -> None:
    """A finished replay whose scene images did not all reach the recorder is incomplete. The
    lockstep waits for the recorder, but a frame goes on unrecorded after a lockstep timeout, and
    without lockstep the publishers' histories overflow when the recorder falls behind."""
    published = int(result.replay.get("frames_published", 0))
    if result.restarts or result.replay.get("state") != "ended":
        return
    got = recorder.received[SCENE_TOPIC]
    if got < published:
        result.fail(
            f"the recorder got {got} of the {published} scene images (the machine was too "
            "loaded for it to keep up): the bag misses frames"
        )


def _stop_nodes(nodes: GraphProcesses, result: RunResult) -> None:
    """Stop every node; one that was still running and does not exit 0 makes the run incomplete
    (the ones that died before were reported when they did)."""
    ended = nodes.exited()
    result.exit_codes = nodes.stop_all()
    for name, code in result.exit_codes.items():
        if code != 0 and name not in ended:
            result.fail(f"{name} {describe_exit(code)} when stopped (see logs/{name}.log)")


def _spin_recorder(executor: Executor, done: threading.Event, result: RunResult) -> None:
    """Spin until `done`. The executor is shut down by its owner after this returns: rclpy's
    EventsExecutor hung, spinning a core, when shut down from another thread during spin()."""
    try:
        while not done.is_set():
            executor.spin_once(timeout_sec=0.1)
    except Exception as error:  # a failing recorder ends the recording, not the process
        result.fail(f"the recorder failed: {error!r}")


def _stopped(result: RunResult) -> bool:
    """A stop signal arrived (Ctrl-C): the run ends early, keeping what was recorded."""
    if stop_signals.requested() and result.interrupted_by is None:
        result.interrupted_by = stop_signals.received()
        result.fail(f"interrupted by {result.interrupted_by}")
    return result.interrupted_by is not None


def _replay(
    nodes: GraphProcesses,
    recorder: Recorder,
    supervisor: Supervisor,
    source_overrides: dict[str, Any],
    timeout: float,
    during: Callable[[ReplayStatus | None, GraphProcesses], None] | None,
) -> None:
    """Start video_source and supervise the graph until the stream ends or the run must stop."""
    nodes.start("video_source", source_overrides)
    _supervise(recorder, supervisor, timeout, during, nodes, input_name(source_overrides["path"]))


def _supervise(
    recorder: Recorder,
    supervisor: Supervisor,
    timeout: float,
    during: Callable[[ReplayStatus | None, GraphProcesses], None] | None,
    nodes: GraphProcesses,
    source: str,
) -> None:
    """Watch the replay until the stream ends or the run must stop; progress on the terminal."""
    result = supervisor.result
    progress = Progress(f"replaying {source}")
    started = time.monotonic()
    recorder_cpu = time.process_time()
    cpu_at_start = nodes.cpu_seconds()
    deadline = started + timeout
    watch = Watch.RUNNING
    while watch is Watch.RUNNING and not _stopped(result):
        if time.monotonic() > deadline:
            result.fail(f"the replay did not finish within {timeout:.0f} s")
            break
        stop_signals.wait(0.05)
        if recorder.status is not None:
            progress.show(recorder.status.frames_published, recorder.status.frames_total)
        if during is not None:
            during(recorder.status, nodes)
        watch = supervisor.check()
        nodes.cpu_seconds()  # keeps each node's CPU time up to date, also for one about to exit
    result.wall_seconds = time.monotonic() - started
    if watch is Watch.ENDED:
        recorder.wait_until_quiet()  # the last frames' messages
        if recorder.status is not None:
            recorder.wait_for_camera_latency(recorder.status.frames_published)
        result.camera_latency = dict(recorder.camera_latency)
    progress.done()
    result.cpu_seconds = {
        **{
            name: spent - cpu_at_start.get(name, 0.0) for name, spent in nodes.cpu_seconds().items()
        },
        "recorder": time.process_time() - recorder_cpu,
    }
    result.callback_load = dict(recorder.callback_load)


def _replay_summary(status: ReplayStatus | None) -> dict[str, Any]:
    if status is None:
        return {}
    states = {
        ReplayStatus.STATE_PLAYING: "playing",
        ReplayStatus.STATE_ENDED: "ended",
        ReplayStatus.STATE_FAILED: "failed",
    }
    return {
        "state": states.get(status.state, str(status.state)),
        "message": status.message,
        "frames_published": int(status.frames_published),
        "frames_total": int(status.frames_total),
        "frames_skipped": int(status.frames_skipped),
        "frames_lost": int(status.frames_lost),
        "lockstep_timeouts": int(status.lockstep_timeouts),
    }


def _wait_for_graph(
    graph: Graph, recorder: Recorder, supervisor: Supervisor, timeout: float = 30.0
) -> bool:
    """Until every downstream node is up and its topics are discovered (`graph.ready`: the
    subscribers each topic needs, the recorder included), so frame 0 is seen.
    False (the result says why) when a node dies for good, time runs out or a stop arrives."""
    result = supervisor.result
    deadline = time.monotonic() + timeout
    while not _stopped(result):
        stop_signals.wait(0.1)
        if supervisor.check() is Watch.STOP:
            return False
        missing = missing_topics(graph, recorder)
        if not missing:
            return True
        if time.monotonic() > deadline:
            result.fail(f"the graph did not come up within {timeout:.0f} s (waiting for {missing})")
            return False
    return False


def _wait_for_matches(graph: Graph, recorder: Recorder, timeout: float = MATCH_TIMEOUT_S) -> bool:
    """Until each topic of `graph.ready` has as many readers as it needs matched by its own
    publisher, and as many readers that have matched the publisher in turn (the nodes'
    diagnostics say), or `timeout`: the counts `_wait_for_graph` reads are this process's view of
    the graph, and under load one end of a pair has been seen to match the other seconds after
    the recorder saw both, so frame 0 (or its pose) was lost. False: a stop arrived."""
    deadline = time.monotonic() + timeout
    while not stop_signals.requested():
        matched = {
            topic: (recorder.readers.get(topic, 0), recorder.readers_matched(topic))
            for topic in graph.ready
        }
        short = {topic: pair for topic, pair in matched.items() if min(pair) < graph.ready[topic]}
        if not short:
            return True
        if time.monotonic() > deadline:
            recorder.get_logger().warning(
                f"publishers and readers still unmatched after {timeout:.0f} s ({short}: "
                "(readers the publisher matched, readers that matched a publisher)); "
                "replaying anyway: the first frames may go unanswered"
            )
            return True
        stop_signals.wait(0.05)
    return False


def report(
    bag: Path, out: Path, render: bool = True, run: RunResult | None = None
) -> run_report.Summary:
    """Summary, MOT tracks and (optionally) the annotated video of a recorded run, complete or
    not; `run` adds the run's own account (complete, problems, restarts) to summary.json."""
    frames = run_report.collect(bag)
    summary = run_report.summarize(frames, run_report.message_counts(frames))
    run_report.write_summary(summary, out / "summary.json", None if run is None else run.as_dict())
    run_report.write_mot(frames, out / "tracks.txt")
    if render and summary.frames:
        progress = Progress("rendering annotated.mp4")
        fps = run_report.stream_fps(frames)

        def show(count: int) -> None:
            if stop_signals.requested():
                raise RenderingInterruptedError
            progress.show(count, summary.frames)

        try:
            run_report.render_video(bag, frames, out / "annotated.mp4", fps, show)
        finally:
            progress.done()
        write_contact_sheet(bag, frames, out / "contact_sheet.png")
    return summary


class RenderingInterruptedError(Exception):
    """A stop signal arrived while the annotated video was being rendered."""


def main(argv: list[str] | None = None) -> int:
    parser = _argument_parser()
    args = parser.parse_args(argv)

    video, note = resolve_video(args.video)
    print(note, flush=True)
    overrides, requested = _overrides_of(args, parser)
    graph = load_graph(args.graph)
    problem = unknown_override_nodes(requested, [with_live_view(graph) if args.live else graph])
    if problem:
        parser.error(problem)
    args.out.mkdir(parents=True, exist_ok=True)
    graph = _graph_to_run(graph, args, parser, overrides)
    run = run_graph(
        graph,
        video,
        args.out,
        overrides,
        install_space(),
        args.timeout,
        RunOptions(
            storage=args.storage,
            respawn_limit=RESPAWN_LIMIT if args.respawn else 0,
            raw_images=args.raw_images,
            single_process=args.single_process,
            executor=args.executor,
        ),
    )
    try:
        summary = report(run.bag, args.out, render=not args.no_video, run=run)
    except RenderingInterruptedError:
        print(f"\nrendering interrupted; {args.out}/summary.json and tracks.txt are written")
        return 130
    _print_outcome(run, summary, video, args)
    return _exit_code(run, summary)


def _argument_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--video",
        help="video file, image folder, rosbag2, or a live stream: rtsp://..., http://... "
        "(MJPEG), /dev/video0 (default: vtest.avi)",
    )
    parser.add_argument(
        "--frames",
        type=int,
        default=None,
        help="publish at most this many frames (a live stream's run ends after them; without "
        "it, Ctrl-C ends the run and the report is still written)",
    )
    parser.add_argument(
        "--out", type=Path, default=Path("out"), help="output directory (default: out)"
    )
    parser.add_argument(
        "--mode",
        choices=("servo", "direct", "hold"),
        help="ptz_controller mode (default: the graph's)",
    )
    parser.add_argument(
        "--graph",
        choices=list(GRAPHS),
        default="surveillance",
        help="surveillance (motion, the default); colour (motion hands its target over to "
        "CamShift, which the camera then follows; seed 001); standard (surveillance behind a "
        "camera that speaks only sensor_msgs, as a real unit's drivers do); small_objects (a "
        "fixed camera over the whole scene, MOG2 and the GM-PHD tracker for many small movers; "
        "seed 004)",
    )
    parser.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    parser.add_argument(
        "--frames-in-flight",
        type=int,
        default=None,
        metavar="N",
        help="lockstep with N frames in flight: the nodes work on different frames at once and "
        "the camera applies each command N frames after its image (deterministic; default: the "
        "graph's, 1 = in series)",
    )
    parser.add_argument("--no-video", action="store_true", help="skip the annotated video")
    parser.add_argument(
        "--raw-images",
        action="store_true",
        help="record the scene and camera images raw (sensor_msgs/Image, ~1.2 GB for vtest.avi) "
        "instead of as JPEG on <topic>/compressed",
    )
    parser.add_argument(
        "--external",
        action="append",
        default=[],
        metavar="NODE",
        help="a node of the graph that runs elsewhere (another host): not started or watched "
        "here, but still waited for before the replay starts",
    )
    parser.add_argument(
        "--single-process",
        action="store_true",
        help="every node in one process on one executor (graph_host): the same tracks, less "
        "inter-process traffic; no --respawn or --external",
    )
    parser.add_argument(
        "--executor",
        choices=list(EXECUTORS),
        default=DEFAULT_EXECUTOR,
        help="the rclpy executor of every node process (or of the one with --single-process) and "
        "of the recorder: events (rclpy's EventsExecutor, the default), single "
        "(SingleThreadedExecutor) or multi (MultiThreadedExecutor)",
    )
    parser.add_argument(
        "--live",
        action="store_true",
        help="also serve the run to the Foxglove app (live_view node, ws://127.0.0.1:8765; "
        "--set live_view.port=N for another port)",
    )
    parser.add_argument(
        "--respawn",
        action="store_true",
        help=f"restart a node that dies (up to {RESPAWN_LIMIT} times each; video_source resumes "
        "at the next frame) instead of ending the run",
    )
    parser.add_argument(
        "--timeout", type=float, default=1800.0, help="give up after this many seconds"
    )
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap")
    return parser


def _overrides_of(
    args: argparse.Namespace, parser: argparse.ArgumentParser
) -> tuple[dict[str, dict[str, Any]], dict[str, None]]:
    """The parameter overrides of --set, --frames, --frames-in-flight and --mode, and the nodes
    --set names (before the runner adds its own); exits through `parser` on a bad value."""
    overrides = parse_overrides(args.set)
    if args.frames is not None:
        if args.frames < 1:
            parser.error("--frames must be at least 1")
        overrides.setdefault("video_source", {})["end_frame"] = args.frames
    requested = dict.fromkeys(overrides)  # the nodes --set names, before the runner adds its own
    if args.frames_in_flight is not None:
        try:
            in_flight = pipelined(args.frames_in_flight)
        except ValueError as error:
            parser.error(f"--frames-in-flight: {error}")
        for node, values in in_flight.items():
            overrides.setdefault(node, {}).update(values)
    if args.mode:
        overrides.setdefault("ptz_controller", {})["mode"] = args.mode
    return overrides, requested


def _graph_to_run(
    graph: Graph,
    args: argparse.Namespace,
    parser: argparse.ArgumentParser,
    overrides: dict[str, dict[str, Any]],
) -> Graph:
    """`graph` without the --external nodes, with the live view when --live (and where to open
    it said); exits through `parser` on an unknown external node or a conflicting option."""
    unknown = set(args.external) - {node.name for node in graph.nodes}
    if unknown:
        parser.error(f"--external: no node {sorted(unknown)} in the {graph.name} graph")
    if args.single_process and (args.external or args.respawn):
        parser.error("--single-process runs every node itself: no --external or --respawn")
    graph = without_nodes(graph, set(args.external))
    if args.live:
        graph = with_live_view(graph)
        port = overrides.get("live_view", {}).get("port", 8765)
        print(f"live view: open ws://127.0.0.1:{port} in Foxglove (Open connection)", flush=True)
    return graph


def _print_outcome(
    run: RunResult, summary: run_report.Summary, video: VideoInput, args: argparse.Namespace
) -> None:
    """The run's summary, replay and camera latency, and what was written to args.out."""
    print(f"\nRun summary ({redacted(str(video))}):\n{run_report.format_summary(summary)}")
    if run.replay:
        replay = run.replay
        print(
            f"  replay: {replay['frames_published']}/{replay['frames_total'] or '?'} frames "
            f"published, {replay['frames_skipped']} skipped, {replay['frames_lost']} lost, "
            f"{replay['lockstep_timeouts']} lockstep timeouts"
            + (f" ({replay['message']})" if replay["message"] else "")
        )
    if run.camera_latency:
        print(f"  {camera_latency_line(run.camera_latency)}")
    products = "bag/, tracks.txt, summary.json, logs/" + (
        "" if args.no_video or not summary.frames else ", annotated.mp4, contact_sheet.png"
    )
    print(f"\nWrote {args.out}/: {products}")


def _exit_code(run: RunResult, summary: run_report.Summary) -> int:
    """run_demo's exit code (0, 1 for an incomplete run or no frames, 130 when interrupted),
    the nodes' warnings and the run's problems said on stderr."""
    if run.node_warnings:
        print("\nThe nodes warned (logs/):\n  " + "\n  ".join(run.node_warnings), file=sys.stderr)
    if not run.complete:
        problems = "\n  ".join(run.problems)
        print(f"\nThe run is INCOMPLETE:\n  {problems}", file=sys.stderr)
        return 130 if run.interrupted_by else 1
    if run.problems:
        print("\nRecovered from:\n  " + "\n  ".join(run.problems), file=sys.stderr)
    return 0 if summary.frames > 0 else 1


def resolve_video(video: str | None) -> tuple[VideoInput, str]:
    """The input to replay (a live stream's URL stays a string: a Path would fold its "//")
    and a line telling the user what it is."""
    if video is not None:
        if is_live_stream(video):
            return video, f"Following the live stream {redacted(video)}"
        if not Path(video).exists():
            raise SystemExit(f"error: {video} does not exist")
        return Path(video), f"Replaying {video}"
    from tracker_ptz_sim.bringup.sample import sample_or_synthetic

    return sample_or_synthetic()


def install_space() -> Path:
    """The workspace's install/ directory this package runs from."""
    prefix = os.environ.get("COLCON_PREFIX_PATH", "").split(os.pathsep)[0]
    if prefix:
        return Path(prefix)
    return (
        Path(__file__).resolve().parents[6]
    )  # .../install/<pkg>/lib/pythonX/site-packages/tracker_ptz_sim/bringup/demo.py


def camera_latency_line(latency: dict[str, float]) -> str:
    """The camera's own image-to-command latency as run_demo prints it."""
    return (
        f"at ptz_camera: camera image -> command p50 {latency['p50']:.1f} ms, "
        f"p95 {latency['p95']:.1f} ms (image out to command in, {int(latency['count'])} frames)"
    )


if __name__ == "__main__":
    raise SystemExit(main())
