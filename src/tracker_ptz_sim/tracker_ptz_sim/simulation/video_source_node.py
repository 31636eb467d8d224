"""video_source: replays a recorded video, image folder or rosbag2 as a camera stream.

Publishes `scene/image_raw` (sensor_msgs/Image, bgr8 or mono8), `scene/camera_info`, `/clock`
(so the graph can run on the recording's time) and `replay/status` (tracker_msgs/ReplayStatus).
Frames are stamped from the recording. Pacing: `rate` x real time, or as fast as possible (rate 0);
with lockstep, frame n also waits for an acknowledgement stamped >= frame n - `frames_in_flight`
on `ack_topic` (tracker_msgs/PtzCommand by default) -- and, given a `recorder_topic`, until a
recorder has received it (run_demo's recorder says so there) -- or for `lockstep_timeout` with a
warning:
1 frame in flight runs the graph in series; more let its nodes work on different frames at once
(give ptz_camera the same `command_delay_frames`, so the replay stays deterministic). At the end
of the stream it waits for the last frames' acknowledgements, publishes STATE_ENDED and exits 0
(unless `loop`).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Header

from tracker_msgs.msg import PtzCommand, ReplayStatus
from tracker_msgs_py.codec import (
    NS_PER_S,
    array_to_image,
    camera_info,
    command_qos,
    image_qos,
    ns_to_stamp,
    stamp_to_ns,
)
from tracker_msgs_py.node_main import Health, StartupError, SuiteNode, run_node
from tracker_msgs_py.params import config_from_params, declare_parameters, param, specs_of
from tracker_ptz_sim.simulation.camera_model import MAX_COMMAND_DELAY_FRAMES
from tracker_ptz_sim.simulation.frame_sources import Frame, FrameSource, SourceError
from tracker_ptz_sim.simulation.live_stream import RTSP_TRANSPORTS, LiveStreamSource, open_input
from tracker_ptz_sim.simulation.replay import Pacer, Prefetcher

STATUS_QOS = QoSProfile(
    depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)


@dataclass(frozen=True)
class VideoSourceConfig:
    """The video source node's parameters."""

    path: str = param(
        "",
        "video file, image folder or rosbag2 to replay, or a live stream: rtsp://, http(s):// "
        "(MJPEG), /dev/videoN",
        read_only=True,
    )
    rate: float = param(
        1.0, "replay speed: 1 = real time, 0 = as fast as the graph allows", min=0.0, max=100.0
    )
    rtsp_transport: str = param(
        "tcp",
        "RTP over the RTSP connection (tcp: a lost camera is noticed at once, nothing dropped on "
        "the way), udp, or auto (FFmpeg's: UDP, then TCP)",
        choices=RTSP_TRANSPORTS,
        read_only=True,
    )
    loop: bool = param(False, "start again at the end instead of exiting")
    start_frame: int = param(
        0, "first frame index to publish", min=0, max=2**31 - 1, read_only=True
    )
    end_frame: int = param(
        -1,
        "stop before this frame index (-1 = the end)",
        min=-1,
        max=2**31 - 1,
        read_only=True,
    )
    fps: float = param(
        0.0,
        "frame rate for the stamps of videos/folders (0 = the video's, folders 10)",
        min=0.0,
        max=1000.0,
        read_only=True,
    )
    bag_topic: str = param(
        "",
        "image topic of a rosbag2 ('' = the first Image/CompressedImage)",
        read_only=True,
    )
    encoding: str = param("bgr8", "published encoding", choices=("bgr8", "mono8"))
    frame_id: str = param("scene", "frame_id of the scene images")
    focal_length: float = param(
        0.0,
        "fx = fy of the scene CameraInfo (0 = image width)",
        min=0.0,
        max=1e6,
        unit="px",
    )
    lockstep: bool = param(
        False,
        "wait for an acknowledgement of each frame before the next",
        read_only=True,
    )
    frames_in_flight: int = param(
        1,
        "lockstep: frames published ahead of the oldest one not yet acknowledged (1 = in "
        "series; ptz_camera's command_delay_frames must be at least this)",
        min=1,
        max=MAX_COMMAND_DELAY_FRAMES,
        read_only=True,
    )
    ack_topic: str = param(
        "ptz/command",
        "acknowledgements: tracker_msgs/PtzCommand stamped >= the frame",
        read_only=True,
    )
    recorder_topic: str = param(
        "",
        "lockstep: also wait until a recorder has received each frame (std_msgs/Header stamped "
        "with it, on this topic; empty: no recorder), so a recording misses none however loaded "
        "the machine",
        read_only=True,
    )
    lockstep_timeout: float = param(
        2.0,
        "give up waiting for an acknowledgement after this",
        min=0.01,
        max=3600.0,
        unit="s",
    )
    wait_for_subscribers: int = param(
        1,
        "lockstep: wait for this many image subscribers first",
        min=0,
        max=100,
        read_only=True,
    )
    publish_clock: bool = param(True, "publish /clock with the frame stamps", read_only=True)
    reliable_images: bool = param(
        False,
        "reliable instead of sensor-data (best effort) image QoS",
        read_only=True,
    )

    def problems(self) -> list[str]:
        return []


PARAMS = specs_of(VideoSourceConfig)


class VideoSourceNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("video_source", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change)
        self.settings = config_from_params(VideoSourceConfig, self.params)
        try:
            self.source = open_input(
                self.settings.path,
                self.settings.fps,
                self.settings.bag_topic,
                self._on_stream,
                self.settings.rtsp_transport,
            )
        except SourceError as error:
            raise StartupError(str(error)) from error
        self.add_waker(self.source.close)
        self.start, self.end = frame_range(
            self.settings.start_frame, self.settings.end_frame, self.source
        )
        self.get_logger().info(f"replaying {self.source.describe()}")
        if self.source.note:
            self.get_logger().warning(self.source.note)
        qos = image_qos(self.settings.reliable_images)
        self.image_pub = self.create_publisher(Image, "scene/image_raw", qos)
        self.info_pub = self.create_publisher(CameraInfo, "scene/camera_info", qos)
        self.status_pub = self.create_publisher(ReplayStatus, "replay/status", STATUS_QOS)
        self.clock_pub = (
            self.create_publisher(Clock, "/clock", CLOCK_QOS)
            if self.settings.publish_clock
            else None
        )
        self.answered_ns = -1  # the newest frame acknowledged on ack_topic
        self.recorded_ns = -1  # the newest frame the recorder has received (with recorder_topic)
        self.published_ns = -1  # stamp of the newest frame published (set before it goes out)
        self.in_flight: deque[int] = deque()  # lockstep: stamps published, not yet acknowledged
        self.ack_event = threading.Event()
        self.pace_event = threading.Event()
        self.pacer = Pacer(self.settings.rate)
        self.ack_sub = (
            self.create_subscription(
                PtzCommand, self.settings.ack_topic, self._on_ack, command_qos()
            )
            if self.settings.lockstep
            else None
        )
        self.recorder_sub = None
        if self.settings.lockstep and self.settings.recorder_topic:
            self.recorder_sub = self.create_subscription(
                Header, self.settings.recorder_topic, self._on_recorded, 10
            )
        self.status = ReplayStatus(source=self.source.label, state=ReplayStatus.STATE_PLAYING)
        self.add_waker(self.ack_event.set)
        self.add_waker(self.pace_event.set)
        self.start_worker(self._replay, "replay")

    def _on_stream(self, level: str, message: str) -> None:
        """A live stream's outage or return (from its reader thread). Two calls: rclpy refuses
        one call site logging at two severities."""
        if level == "warning":
            self.get_logger().warning(message)
        else:
            self.get_logger().info(message)

    def diagnostic_health(self) -> tuple[Health, str]:
        if isinstance(self.source, LiveStreamSource) and not self.source.connected:
            return Health.WARN, f"{self.source.label}: stream lost, reconnecting"
        return Health.OK, ""

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        names = {
            ReplayStatus.STATE_PLAYING: "replaying",
            ReplayStatus.STATE_ENDED: "ended",
            ReplayStatus.STATE_FAILED: "failed",
        }
        status = self.status
        details = {
            "source": status.source,
            "frame index": str(status.frame_index),
            "frames published": str(status.frames_published),
        }
        if isinstance(self.source, LiveStreamSource):
            details["frames dropped (newer one came first)"] = str(self.source.dropped)
            details["reconnects"] = str(self.source.reconnects)
        return names.get(status.state, str(status.state)), details

    @property
    def acked_ns(self) -> int:
        """The newest frame both answered and (with a recorder) recorded."""
        if self.recorder_sub is None:
            return self.answered_ns
        return min(self.answered_ns, self.recorded_ns)

    def _forget_acks(self) -> None:
        self.answered_ns = self.recorded_ns = -1

    def _current(self, stamp_ns: int) -> bool:
        """An acknowledgement stamped after every frame published answers another replay (the
        one before a restart, still draining the graph): taken, it would let frames through
        unanswered."""
        return stamp_ns <= self.published_ns

    def _on_ack(self, msg: PtzCommand) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        if self._current(stamp) and stamp > self.answered_ns:
            self.answered_ns = stamp
            self.ack_event.set()

    def _on_recorded(self, msg: Header) -> None:
        stamp = stamp_to_ns(msg.stamp)
        if self._current(stamp) and stamp > self.recorded_ns:
            self.recorded_ns = stamp
            self.ack_event.set()

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(VideoSourceConfig, self.params)
        if "rate" in changed:
            self.pacer.set_rate(self.settings.rate, time.monotonic())
            self.pace_event.set()  # a frame waiting on the old schedule is rescheduled

    # --- the replay worker ----------------------------------------------------------------------

    def _replay(self) -> None:
        try:
            self._wait_for_subscribers()
            self.status.frames_total = len(range(self.start, self.end or self.source.total))
            while not self.stopping.is_set():
                published = self.status.frames_published
                self._play_once()
                if self.stopping.is_set():
                    return
                if self.status.frames_published == published:
                    raise SourceError(
                        f"{self.source.label}: no frame could be read in "
                        f"[{self.start}, {self.end if self.end is not None else 'end'})"
                    )
                if not self.settings.loop or self.source.live:
                    break
            if not self.stopping.is_set():
                reason = "end_frame reached" if self.source.live else "end of stream"
                self._end(ReplayStatus.STATE_ENDED, reason, 0)
        except Exception as error:  # anything reading the input: report it, exit non-zero
            if self.stopping.is_set():
                return  # a shutdown interrupted the replay: not a failure
            if isinstance(error, SourceError) and self.status.frames_published == 0:
                # the input itself is bad (a folder of unreadable images): as at start-up
                self.get_logger().fatal(str(error))
                self._end(ReplayStatus.STATE_FAILED, str(error), 2)
                return
            self.get_logger().error(f"replay of {self.source.label} failed: {error}")
            self._end(ReplayStatus.STATE_FAILED, str(error), 1)

    def _wait_for_subscribers(self) -> None:
        """Lockstep: wait for the image subscribers and for someone publishing acknowledgements,
        each matched by this node's own publisher and subscription (not only seen in the graph),
        so frame 0 is neither lost nor waits for an ack that cannot come."""
        if self.ack_sub is None:
            return
        wanted = self.settings.wait_for_subscribers
        ack_topic, ack_sub, recorder_sub = self.settings.ack_topic, self.ack_sub, self.recorder_sub

        def ready() -> bool:
            return (
                self.image_pub.get_subscription_count() >= wanted
                and ack_sub.get_publisher_count() > 0
                and (recorder_sub is None or recorder_sub.get_publisher_count() > 0)
            )

        if not ready():
            recorder = "" if recorder_sub is None else f" and of {self.settings.recorder_topic}"
            self.get_logger().info(
                f"lockstep: waiting for {wanted} subscriber(s) of scene/image_raw and a publisher "
                f"of {ack_topic}{recorder}"
            )
        while not self.stopping.is_set() and not ready():
            self.stopping.wait(0.02)
        self.stopping.wait(0.2)  # let the acknowledgement publisher finish matching us

    def _play_once(self) -> None:
        """One pass over [start, end). Stamps keep increasing across loops: a pass after the
        first starts one frame period after the last stamp sent. A live stream's stamps are its
        arrival times."""
        live = self.source.live
        next_stamp = (
            stamp_to_ns(self.status.header.stamp) + round(NS_PER_S / self.source.fps)
            if self.status.frames_published and not live
            else None
        )
        offset: int | None = None
        # A live stream hands out its newest frame when asked: read ahead, it would be stale.
        stream = self.source.frames(self.start, self.end)
        frames = stream if live else Prefetcher(stream)
        try:
            for frame in frames:
                if offset is None:
                    offset = 0 if next_stamp is None or live else next_stamp - frame.stamp_ns
                stamp = frame.stamp_ns + offset
                if not live:  # a live stream comes at its own pace
                    self._pace(stamp)
                if self.stopping.is_set():
                    return
                self._publish(frame, stamp)
                if self.settings.lockstep:
                    self.in_flight.append(stamp)
                    self._wait_for_acks(self.settings.frames_in_flight - 1)
            if self.settings.lockstep:
                self._wait_for_acks(0)  # a pass ends answered: a loop starts a new epoch
        finally:
            if isinstance(frames, Prefetcher):
                frames.close()
            else:
                self.source.close()  # a live stream's pass ends the stream

    def _pace(self, stamp_ns: int) -> None:
        while not self.stopping.is_set():
            self.pace_event.clear()
            delay = self.pacer.delay(stamp_ns, time.monotonic())
            if delay <= 0:
                return
            self.pace_event.wait(delay)

    def _publish(self, frame: Frame, stamp_ns: int) -> None:
        if stamp_ns <= self.published_ns:
            self._forget_acks()  # time went back (a loop): older acknowledgements answer nothing
            self.in_flight.clear()
        self.published_ns = stamp_ns
        stamp = ns_to_stamp(stamp_ns)
        if self.clock_pub is not None:
            self.clock_pub.publish(Clock(clock=stamp))
        image = frame.image
        if self.settings.encoding == "mono8":
            import cv2

            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        frame_id = self.settings.frame_id
        height, width = image.shape[:2]
        focal = self.settings.focal_length or float(width)
        self.last_sent = (
            camera_info(width, height, focal, focal, width / 2, height / 2, stamp, frame_id),
            array_to_image(image, self.settings.encoding, stamp, frame_id),
        )
        # The status goes first: a runner that restarts a killed source at the frame after the
        # last status may then lose the frame in flight, but never sends one twice.
        self.status.header.stamp = stamp
        self.status.header.frame_id = frame_id
        self.status.frame_index = frame.index
        self.status.frames_published += 1
        self._note_damage()
        self.status_pub.publish(self.status)
        self.info_pub.publish(self.last_sent[0])
        self.image_pub.publish(self.last_sent[1])
        self.pacer.sent(stamp_ns)

    def _note_damage(self) -> None:
        if self.source.skipped > self.status.frames_skipped:
            cause = f" ({self.source.skip_cause})" if self.source.skip_cause else ""
            self.problems.report(
                "undecodable frame",
                f"skipped {self.source.skipped - self.status.frames_skipped} undecodable "
                f"frame(s) of {self.source.label} before frame {self.status.frame_index}{cause}",
            )
            self.status.frames_skipped = self.source.skipped
        self.status.frames_lost = self.source.lost

    def _wait_for_acks(self, allowed: int) -> None:
        """Until at most `allowed` frames published are unacknowledged (each waited for in turn,
        with its timeout)."""
        while self.in_flight and not self.stopping.is_set():
            while self.in_flight and self.in_flight[0] <= self.acked_ns:
                self.in_flight.popleft()
            if len(self.in_flight) <= allowed:
                return
            self._wait_for_ack(self.in_flight.popleft())

    def _wait_for_ack(self, stamp_ns: int) -> None:
        """Until frame `stamp_ns` is acknowledged, or the timeout. Halfway through, the newest
        frame is sent once more: a frame published while a subscriber was still completing
        discovery can be lost, and every node drops the repeat of a frame it did get (an
        acknowledgement of a newer frame answers the older ones too)."""
        timeout = self.settings.lockstep_timeout
        deadline = time.monotonic() + timeout
        resend_at: float | None = time.monotonic() + timeout / 2
        while self.acked_ns < stamp_ns and not self.stopping.is_set():
            if resend_at is not None and time.monotonic() >= resend_at:
                resend_at = None
                self.info_pub.publish(self.last_sent[0])
                self.image_pub.publish(self.last_sent[1])
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self.status.lockstep_timeouts += 1
                waited_for = (
                    f"recording on {self.settings.recorder_topic}"
                    if self.answered_ns >= stamp_ns
                    else f"acknowledgement on {self.settings.ack_topic}"
                )
                self.get_logger().warning(
                    f"no {waited_for} of the frame stamped {stamp_ns / NS_PER_S:.3f} s within "
                    f"{self.settings.lockstep_timeout} s; going on",
                    throttle_duration_sec=5.0,
                )
                return
            self.ack_event.clear()
            if self.acked_ns < stamp_ns:
                self.ack_event.wait(remaining if resend_at is None else min(remaining, timeout / 2))

    def _end(self, state: int, message: str, exit_code: int) -> None:
        """Publish the final status (kept for late joiners: transient local), log, and finish."""
        self._note_damage()
        if self.source.end_note:
            message = f"{message}; {self.source.end_note}"
        self.status.state = state
        self.status.message = message
        self.status_pub.publish(self.status)
        self.status_pub.wait_for_all_acked(Duration(seconds=0.5))
        line = (
            f"{message} ({self.status.frames_published} frames published, "
            f"{self.status.frames_skipped} skipped, {self.status.frames_lost} lost, "
            f"{self.status.lockstep_timeouts} lockstep timeouts)"
        )
        # a live stream's lost frames are the ones a newer frame replaced: no damage
        damaged = self.status.frames_skipped or (self.status.frames_lost and not self.source.live)
        (self.get_logger().warning if damaged else self.get_logger().info)(line)
        self.finish(exit_code)


def frame_range(start: int, end_frame: int, source: FrameSource) -> tuple[int, int | None]:
    """[start, end) of the replay (end None = to the end); StartupError when it is empty."""
    end = None if end_frame < 0 else end_frame
    if end is not None and end <= start:
        raise StartupError(
            f"{source.path}: end_frame {end} must be greater than start_frame {start}"
        )
    if source.total and start >= source.total:
        raise StartupError(
            f"{source.path}: start_frame {start} is past the end (the input has "
            f"{source.total} frames, 0 to {source.total - 1})"
        )
    return start, end


def main(args: list[str] | None = None) -> int:
    return run_node(VideoSourceNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
