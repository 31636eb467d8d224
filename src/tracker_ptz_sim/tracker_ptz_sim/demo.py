"""run_demo: the whole surveillance graph as separate processes, recorded and summarised.

    run_demo [--video PATH] [--out out] [--mode servo|direct] [--set node.param=value ...]

Starts every node of config/graph.yaml from the install space (exactly as `ros2 run` would) with
config/surveillance.yaml, replays the video in lockstep, records every topic into an MCAP bag with
`rosbags`, shows progress, and writes to the output directory:
    bag/            rosbag2 (MCAP) of every topic
    annotated.mp4   scene with camera window, blobs, tracks, target; camera view beside it
    tracks.txt      confirmed tracks, MOTChallenge format
    summary.json    frames, throughput, per-hop latency, lock share, centring error (also printed)
    logs/           one log per node
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from tracker_msgs.msg import ReplayStatus
from tracker_ptz_sim import run_report
from tracker_ptz_sim.graph import Graph, executable_path, load_graph, ros_args
from tracker_ptz_sim.recording import BagWriter

RECORD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=200,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
CLOCK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=50, reliability=ReliabilityPolicy.BEST_EFFORT
)
STATUS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


class Recorder(Node):
    """Records the graph's topics (serialized, as received) and follows the replay's progress."""

    def __init__(self, graph: Graph, bag: BagWriter) -> None:
        super().__init__("run_recorder")
        self.bag = bag
        self.status: ReplayStatus | None = None
        self._keep = []
        for topic in graph.topics:
            msg_type = _import_type(topic.type)
            qos = CLOCK_QOS if topic.name == "/clock" else RECORD_QOS
            self._keep.append(
                self.create_subscription(
                    msg_type,
                    topic.name,
                    lambda data, name=topic.name: self._record(name, data),
                    qos,
                    raw=True,
                )
            )
        self.create_subscription(ReplayStatus, "/replay/status", self._on_status, STATUS_QOS)

    def _record(self, topic: str, data: bytes) -> None:
        self.bag.write(topic, time.time_ns(), data)

    def _on_status(self, status: ReplayStatus) -> None:
        self.status = status


def _import_type(name: str) -> Any:
    package, kind, message = name.split("/")
    module = __import__(f"{package}.{kind}", fromlist=[message])
    return getattr(module, message)


class GraphProcesses:
    """The graph's nodes as child processes started from the install space, one log file each."""

    def __init__(self, graph: Graph, install_dir: Path, log_dir: Path) -> None:
        self.graph = graph
        self.install_dir = install_dir
        self.log_dir = log_dir
        self.processes: dict[str, subprocess.Popen] = {}
        log_dir.mkdir(parents=True, exist_ok=True)

    def start(self, name: str, overrides: dict[str, Any] | None = None) -> subprocess.Popen:
        node = self.graph.node(name)
        command = [str(executable_path(self.install_dir, node))]
        command += ros_args(node, self.graph.params_file, overrides)
        log = (self.log_dir / f"{name}.log").open("a")
        self.processes[name] = subprocess.Popen(
            command,
            stdout=log,
            stderr=subprocess.STDOUT,
            env=dict(os.environ),
            start_new_session=True,
        )
        return self.processes[name]

    def kill(self, name: str) -> None:
        """SIGKILL a node (as a crash would); it is no longer watched until started again."""
        process = self.processes.pop(name)
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()

    def stop_all(self, timeout: float = 5.0) -> dict[str, int]:
        """SIGINT every node, escalate to SIGKILL after `timeout`; the exit codes by node."""
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + timeout
        codes = {}
        for name, process in self.processes.items():
            try:
                codes[name] = process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                codes[name] = process.wait()
        return codes

    def cpu_seconds(self) -> dict[str, float]:
        """CPU time (user + system) each running node has used so far, from /proc."""
        ticks = os.sysconf("SC_CLK_TCK")
        used = {}
        for name, process in self.processes.items():
            try:
                fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            used[name] = (int(fields[11]) + int(fields[12])) / ticks  # utime, stime
        return used

    def crashed(self) -> dict[str, int]:
        """Nodes that exited with an error (video_source exits 0 at the end of the stream)."""
        return {
            name: code
            for name, process in self.processes.items()
            if (code := process.poll()) is not None and code != 0
        }


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
    exit_codes: dict[str, int]  # by node
    cpu_seconds: dict[str, float]  # by node, plus "recorder" for this process
    wall_seconds: float  # from the first frame published to the end of the stream


def run_graph(
    graph: Graph,
    video: Path,
    out: Path,
    overrides: dict[str, dict[str, Any]],
    install_dir: Path,
    timeout: float,
    storage: str = "mcap",
    during: Callable[[ReplayStatus | None, GraphProcesses], None] | None = None,
) -> RunResult:
    """Replay `video` through the graph, recording every topic into out/bag.

    `during(status, nodes)` is called while the replay runs (tests use it to kill and restart
    nodes); a node that crashes on its own ends the run with an error.
    """
    bag_path = out / "bag"
    if bag_path.exists():
        shutil.rmtree(bag_path)
    bag = BagWriter(bag_path, {t.name: t.type for t in graph.topics}, storage)
    rclpy.init(args=["--ros-args", "--disable-rosout-logs"])
    recorder = Recorder(graph, bag)
    # The recorder spins in its own thread: one executor for the whole run is far cheaper per
    # message than spin_once from the supervising loop below.
    executor = SingleThreadedExecutor()
    executor.add_node(recorder)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    nodes = GraphProcesses(graph, install_dir, out / "logs")
    progress = Progress(f"replaying {video.name}")
    cpu: dict[str, float] = {}
    started = time.monotonic()
    try:
        # The first frame goes out once ptz_camera and this recorder both listen.
        source_overrides = {
            "path": str(video),
            "wait_for_subscribers": 2,
            **overrides.get("video_source", {}),
        }
        for node in graph.nodes:
            if node.name != "video_source":
                nodes.start(node.name, overrides.get(node.name))
        _wait_for_graph(recorder, nodes)
        # The counts above are this process's view; give the nodes a moment to finish matching
        # each other too, so frame 0 is not published into a half-discovered graph.
        time.sleep(1.0)
        source = nodes.start("video_source", source_overrides)
        started = time.monotonic()
        recorder_cpu = time.process_time()
        deadline = time.monotonic() + timeout
        while source.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
            if recorder.status is not None:
                progress.show(recorder.status.frames_published, recorder.status.frames_total)
            if during is not None:
                during(recorder.status, nodes)
            crashed = nodes.crashed()
            if crashed:
                raise RuntimeError(f"nodes crashed: {crashed}; see {out / 'logs'}")
        if source.poll() is None:
            raise TimeoutError(f"the replay did not finish within {timeout:.0f} s")
        wall = time.monotonic() - started
        time.sleep(1.0)  # the last frame's messages
        progress.done()
        cpu = {**nodes.cpu_seconds(), "recorder": time.process_time() - recorder_cpu}
    finally:
        codes = nodes.stop_all()
        executor.shutdown()
        spinner.join(timeout=5.0)
        recorder.destroy_node()
        rclpy.try_shutdown()
        bag.close()
    return RunResult(bag_path, codes, cpu, wall)


# Subscribers each topic needs before the first frame, counting the recorder (so no frame is lost
# while the graph is still discovering itself).
EXPECTED_SUBSCRIBERS = {
    "/camera/image_raw": 2,  # ssim_detector, recorder
    "/ptz/state": 4,  # ssim_detector, tracker, ptz_controller, recorder
    "/detections": 2,  # tracker, recorder
    "/target": 2,  # ptz_controller, recorder
    "/ptz/command": 2,  # ptz_camera, recorder (video_source's comes with it)
}


def _wait_for_graph(recorder: Recorder, nodes: GraphProcesses, timeout: float = 30.0) -> None:
    """Until every downstream node is up and its topics are discovered, so frame 0 is seen."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        time.sleep(0.1)
        if nodes.crashed():
            raise RuntimeError(f"nodes crashed at start-up: {nodes.crashed()}")
        missing = {
            topic: wanted
            for topic, wanted in EXPECTED_SUBSCRIBERS.items()
            if recorder.count_publishers(topic) == 0 or recorder.count_subscribers(topic) < wanted
        }
        if not missing:
            return
    raise TimeoutError(f"the graph did not come up within {timeout:.0f} s (waiting for {missing})")


def report(bag: Path, out: Path, render: bool = True) -> run_report.Summary:
    """Summary, MOT tracks and (optionally) the annotated video of a recorded run."""
    frames = run_report.collect(bag)
    summary = run_report.summarize(frames, run_report.message_counts(frames))
    run_report.write_summary(summary, out / "summary.json")
    run_report.write_mot(frames, out / "tracks.txt")
    if render:
        progress = Progress("rendering annotated.mp4")
        fps = run_report.stream_fps(frames)
        run_report.render_video(
            bag, frames, out / "annotated.mp4", fps, lambda n: progress.show(n, summary.frames)
        )
        progress.done()
    return summary


def parse_overrides(items: list[str]) -> dict[str, dict[str, Any]]:
    """--set node.param=value (values parsed as YAML: 0.5, true, [1, 2], text)."""
    import yaml

    overrides: dict[str, dict[str, Any]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        node, dot, param = key.partition(".")
        if not sep or not dot:
            raise SystemExit(f"--set expects node.param=value, got '{item}'")
        overrides.setdefault(node, {})[param] = yaml.safe_load(value)
    return overrides


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--video", type=Path, help="video file, image folder or rosbag2 (default: vtest.avi)"
    )
    parser.add_argument(
        "--out", type=Path, default=Path("out"), help="output directory (default: out)"
    )
    parser.add_argument("--mode", choices=("servo", "direct"), help="ptz_controller mode")
    parser.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    parser.add_argument("--no-video", action="store_true", help="skip the annotated video")
    parser.add_argument(
        "--timeout", type=float, default=1800.0, help="give up after this many seconds"
    )
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap")
    args = parser.parse_args(argv)

    video, note = resolve_video(args.video)
    print(note, flush=True)
    overrides = parse_overrides(args.set)
    if args.mode:
        overrides.setdefault("ptz_controller", {})["mode"] = args.mode
    args.out.mkdir(parents=True, exist_ok=True)
    graph = load_graph()
    run = run_graph(graph, video, args.out, overrides, install_space(), args.timeout, args.storage)
    failed = {name: code for name, code in run.exit_codes.items() if code != 0}
    summary = report(run.bag, args.out, render=not args.no_video)
    print(f"\nRun summary ({video}):\n{run_report.format_summary(summary)}")
    products = "bag/, tracks.txt, summary.json, logs/" + (
        "" if args.no_video else ", annotated.mp4"
    )
    print(f"\nWrote {args.out}/: {products}")
    if failed:
        print(f"nodes exited with errors: {failed} (see {args.out}/logs)", file=sys.stderr)
        return 1
    return 0 if summary.frames > 0 else 1


def resolve_video(video: Path | None) -> tuple[Path, str]:
    """The input to replay and a line telling the user what it is."""
    if video is not None:
        if not video.exists():
            raise SystemExit(f"error: {video} does not exist")
        return video, f"Replaying {video}"
    from tracker_ptz_sim.sample import sample_or_synthetic

    return sample_or_synthetic()


def install_space() -> Path:
    """The workspace's install/ directory this package runs from."""
    prefix = os.environ.get("COLCON_PREFIX_PATH", "").split(os.pathsep)[0]
    if prefix:
        return Path(prefix)
    return Path(__file__).resolve().parents[5]


if __name__ == "__main__":
    raise SystemExit(main())
