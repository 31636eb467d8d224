"""Replay benchmark: video_source -> ptz_camera on vtest.avi (768x576) as fast as possible.

Two modes, both as separate processes started from the install space:
- lockstep: this process acknowledges every camera image at once (a controller that costs
  nothing), so no frame is lost and the number is the pair's deterministic throughput; in series
  (1 frame in flight) and pipelined (2 and 3 frames in flight, the camera delaying each command
  as many frames); every process on rclpy's EventsExecutor (the nodes' default), and in series
  and with 2 in flight on the SingleThreadedExecutor for comparison;
- free-running: rate 0 without lockstep, the clip looping; over a steady window of
  FREE_RUNNING_WINDOW_S once the camera's first image is through (a free-running source does not
  wait for its readers, so how many of the very first frames pass depends on discovery), frames
  published (from replay/status), frames through the camera, and the share the camera could not
  keep up with (sensor-data QoS drops them).
Prints throughput and the hop's latency (median, p95; lockstep) and writes out/bench/replay.json.
Target (issue 16): >= 300 frames/s lockstep.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np
import rclpy
from rclpy.executors import Executor
from rclpy.node import Node
from sensor_msgs.msg import Image

from tracker_msgs.msg import PtzCommand, ReplayStatus
from tracker_msgs_py.codec import image_qos, stamp_to_ns
from tracker_msgs_py.node_main import DEFAULT_EXECUTOR, EXECUTORS
from tracker_ptz_sim.bringup.demo import install_space
from tracker_ptz_sim.bringup.graph import load_graph, pipelined
from tracker_ptz_sim.bringup.processes import GraphProcesses
from tracker_ptz_sim.bringup.sample import sample_or_synthetic
from tracker_ptz_sim.simulation.video_source_node import STATUS_QOS

OUT = Path("out/bench")
FREE_RUNNING_WINDOW_S = 4.0


class Probe(Node):
    """Receive times of scene and camera images; optionally acknowledges each camera image."""

    def __init__(self, acknowledge: bool, scene_times: bool) -> None:
        super().__init__("replay_probe")
        self.scene: dict[int, int] = {}
        self.camera: dict[int, int] = {}
        self.acknowledge = acknowledge
        self.ack_pub = self.create_publisher(PtzCommand, "ptz/command", 10)
        qos = image_qos(reliable=acknowledge)
        if scene_times:
            # A second reader of the 1.3 MB scene images costs as much CPU as the camera's
            # reading, and the graph has none: only the latency runs have it.
            self.create_subscription(Image, "scene/image_raw", self._on_scene, qos)
        self.create_subscription(Image, "camera/image_raw", self._on_camera, qos)
        self.published = 0
        self.create_subscription(ReplayStatus, "replay/status", self._on_status, STATUS_QOS)

    def _on_status(self, msg: ReplayStatus) -> None:
        self.published = max(self.published, int(msg.frames_published))

    def _on_scene(self, msg: Image) -> None:
        self.scene[stamp_to_ns(msg.header.stamp)] = time.perf_counter_ns()

    def _on_camera(self, msg: Image) -> None:
        self.camera[stamp_to_ns(msg.header.stamp)] = time.perf_counter_ns()
        if self.acknowledge:
            ack = PtzCommand(mode=PtzCommand.MODE_HOLD)
            ack.header.stamp = msg.header.stamp
            self.ack_pub.publish(ack)


def spin_for(spinner: Executor, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        spinner.spin_once(timeout_sec=0.01)


def run(
    video: Path,
    lockstep: bool,
    frames_in_flight: int = 1,
    scene_times: bool = False,
    executor: str = DEFAULT_EXECUTOR,
) -> dict:
    """One replay; `scene_times` also reads the scene images, for the hop's latency; `executor`
    is what the two nodes and this process spin."""
    rclpy.init()
    probe = Probe(acknowledge=lockstep, scene_times=scene_times)
    spinner = EXECUTORS[executor]()
    spinner.add_node(probe)
    with tempfile.TemporaryDirectory() as logs:
        nodes = GraphProcesses(load_graph(), install_space(), Path(logs), executor=executor)
        common = {"lockstep": lockstep, "reliable_images": lockstep, "use_sim_time": False}
        in_flight = pipelined(frames_in_flight)
        nodes.start("ptz_camera", {**common, **in_flight["ptz_camera"]})
        deadline = time.monotonic() + 30
        while probe.count_publishers("camera/image_raw") == 0 and time.monotonic() < deadline:
            spinner.spin_once(timeout_sec=0.05)
        source = {
            **common,
            **in_flight["video_source"],
            "path": str(video),
            "rate": 0.0,
            "wait_for_subscribers": 2 if scene_times else 1,
        }
        if lockstep:
            process = nodes.start("video_source", source)
            while process.poll() is None:
                spinner.spin_once(timeout_sec=0.01)
            spin_for(spinner, 1.0)
        else:
            nodes.start("video_source", {**source, "loop": True})
            deadline = time.monotonic() + 30
            while not probe.camera and time.monotonic() < deadline:
                spinner.spin_once(timeout_sec=0.01)
            spin_for(spinner, 0.5)  # past start-up
            start = (len(probe.camera), probe.published, time.perf_counter_ns())
            spin_for(spinner, FREE_RUNNING_WINDOW_S)
            end = (len(probe.camera), probe.published, time.perf_counter_ns())
        nodes.stop_all()
    spinner.shutdown()
    probe.destroy_node()
    rclpy.shutdown()
    if not lockstep:
        through, published = end[0] - start[0], end[1] - start[1]
        seconds = (end[2] - start[2]) / 1e9
        return {
            "mode": "free-running",
            "executor": executor,
            "frames_in_flight": None,
            "frames_published": published,
            "frames_through_camera": through,
            "published_fps": published / seconds,
            "throughput_fps": through / seconds,
            "dropped_share": 1.0 - through / published if published else float("nan"),
            "latency_ms_p50": float("nan"),
            "latency_ms_p95": float("nan"),
        }
    hop = [(probe.camera[s] - probe.scene[s]) / 1e6 for s in probe.camera if s in probe.scene] or [
        float("nan")
    ]
    times = sorted(probe.camera.values())
    duration = (times[-1] - times[0]) / 1e9 if len(times) > 1 else float("nan")
    return {
        "mode": "lockstep",
        "executor": executor,
        "frames_in_flight": frames_in_flight,
        "scene_times": scene_times,
        "frames_published": probe.published,
        "frames_through_camera": len(probe.camera),
        "throughput_fps": (len(times) - 1) / duration,
        "latency_ms_p50": float(np.percentile(hop, 50)),
        "latency_ms_p95": float(np.percentile(hop, 95)),
    }


def main() -> int:
    video, note = sample_or_synthetic()
    print(note)
    results = [run(video, lockstep=True, frames_in_flight=n) for n in (1, 2, 3)]
    results += [run(video, True, frames_in_flight=n, executor="single") for n in (1, 2)]
    results += [run(video, lockstep=True, frames_in_flight=n, scene_times=True) for n in (1, 2)]
    results.append(run(video, lockstep=False))
    print(f"\nvideo_source -> ptz_camera on {video.name}:")
    print(
        f"  {'mode':<50} {'frames in':>9} {'through':>8} {'frames/s':>9} {'hop p50':>8} "
        f"{'hop p95':>8}"
    )
    for r in results:
        mode = r["mode"] + (
            f", {r['frames_in_flight']} in flight" if r["frames_in_flight"] is not None else ""
        )
        mode += ", scene read" if r.get("scene_times") else ""
        mode += ", single executor" if r["executor"] == "single" else ""
        print(
            f"  {mode:<50} {r['frames_published']:>9} {r['frames_through_camera']:>8} "
            f"{r['throughput_fps']:>9.1f} {r['latency_ms_p50']:>6.2f}ms {r['latency_ms_p95']:>6.2f}ms"
        )
    free = results[-1]
    print(
        f"  free-running over {FREE_RUNNING_WINDOW_S:.0f} s: {free['published_fps']:.0f} frames/s "
        f"published, {100 * free['dropped_share']:.0f} % of them dropped before the camera"
    )
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "replay.json").write_text(
        json.dumps({"video": str(video), "runs": results}, indent=2) + "\n"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
