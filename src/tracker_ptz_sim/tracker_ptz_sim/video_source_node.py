"""video_source: replays a recorded video, image folder or rosbag2 as a camera stream.

Publishes `scene/image_raw` (sensor_msgs/Image, bgr8 or mono8), `scene/camera_info`, `/clock`
(so the graph can run on the recording's time) and `replay/status` (tracker_msgs/ReplayStatus).
Frames are stamped from the recording. Pacing: `rate` x real time, or as fast as possible (rate 0);
with lockstep, frame n+1 also waits for an acknowledgement stamped >= frame n on `ack_topic`
(tracker_msgs/PtzCommand by default), or for `lockstep_timeout` with a warning. At
the end of the stream it publishes STATE_ENDED and exits 0 (unless `loop`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from queue import Full, Queue

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image

from tracker_msgs.msg import PtzCommand, ReplayStatus
from tracker_msgs_py.conversions import (
    array_to_image,
    camera_info,
    image_qos,
    ns_to_stamp,
    stamp_to_ns,
)
from tracker_msgs_py.node_main import StartupError, run_node
from tracker_msgs_py.params import ParamSpec, declare_parameters
from tracker_ptz_sim.frame_sources import Frame, SourceError, open_source

STATUS_QOS = QoSProfile(
    depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)

PARAMS = [
    ParamSpec("path", "", "video file, image folder or rosbag2 to replay", read_only=True),
    ParamSpec(
        "rate", 1.0, "replay speed: 1 = real time, 0 = as fast as the graph allows", 0.0, 100.0
    ),
    ParamSpec("loop", False, "start again at the end instead of exiting"),
    ParamSpec("start_frame", 0, "first frame index to publish", 0, 2**31 - 1, read_only=True),
    ParamSpec(
        "end_frame",
        -1,
        "stop before this frame index (-1 = the end)",
        -1,
        2**31 - 1,
        read_only=True,
    ),
    ParamSpec(
        "fps",
        0.0,
        "frame rate for the stamps of videos/folders (0 = the video's, folders 10)",
        0.0,
        1000.0,
        read_only=True,
    ),
    ParamSpec(
        "bag_topic",
        "",
        "image topic of a rosbag2 ('' = the first Image/CompressedImage)",
        read_only=True,
    ),
    ParamSpec("encoding", "bgr8", "published encoding", choices=("bgr8", "mono8")),
    ParamSpec("frame_id", "scene", "frame_id of the scene images"),
    ParamSpec(
        "focal_length", 0.0, "fx = fy of the scene CameraInfo [px] (0 = image width)", 0.0, 1e6
    ),
    ParamSpec(
        "lockstep",
        False,
        "wait for an acknowledgement of each frame before the next",
        read_only=True,
    ),
    ParamSpec(
        "ack_topic",
        "ptz/command",
        "acknowledgements: tracker_msgs/PtzCommand stamped >= the frame",
        read_only=True,
    ),
    ParamSpec(
        "lockstep_timeout",
        2.0,
        "give up waiting for an acknowledgement after this [s]",
        0.01,
        3600.0,
    ),
    ParamSpec(
        "wait_for_subscribers",
        1,
        "lockstep: wait for this many image subscribers first",
        0,
        100,
        read_only=True,
    ),
    ParamSpec("publish_clock", True, "publish /clock with the frame stamps", read_only=True),
    ParamSpec(
        "reliable_images",
        False,
        "reliable instead of sensor-data (best effort) image QoS",
        read_only=True,
    ),
]


class VideoSourceNode(Node):
    def __init__(self) -> None:
        super().__init__("video_source")
        self.params = declare_parameters(self, PARAMS)
        try:
            self.source = open_source(
                self.params["path"], self.params["fps"], self.params["bag_topic"]
            )
        except SourceError as error:
            raise StartupError(str(error)) from error
        self.get_logger().info(f"replaying {self.source.describe()}")
        qos = image_qos(self.params["reliable_images"])
        self.image_pub = self.create_publisher(Image, "scene/image_raw", qos)
        self.info_pub = self.create_publisher(CameraInfo, "scene/camera_info", qos)
        self.status_pub = self.create_publisher(ReplayStatus, "replay/status", STATUS_QOS)
        self.clock_pub = (
            self.create_publisher(Clock, "/clock", CLOCK_QOS)
            if self.params["publish_clock"]
            else None
        )
        self.acked_ns = -1
        self.ack_event = threading.Event()
        if self.params["lockstep"]:
            self.create_subscription(PtzCommand, self.params["ack_topic"], self._on_ack, 10)
        self.status = ReplayStatus(source=str(self.source.path), state=ReplayStatus.STATE_PLAYING)
        self.exit_code = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._replay, daemon=True)
        self._thread.start()

    def _on_ack(self, msg: PtzCommand) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        if stamp > self.acked_ns:
            self.acked_ns = stamp
            self.ack_event.set()

    def destroy_node(self) -> None:
        self._stop.set()
        self.ack_event.set()
        super().destroy_node()

    # --- the replay thread ----------------------------------------------------------------------

    def _replay(self) -> None:
        try:
            self._wait_for_subscribers()
            end = None if self.params["end_frame"] < 0 else self.params["end_frame"]
            self.status.frames_total = len(
                range(self.params["start_frame"], end or self.source.total)
            )
            while not self._stop.is_set():
                self._play_once(self.params["start_frame"], end)
                if not self.params["loop"] or self.status.frames_published == 0:
                    break
            self._finish(ReplayStatus.STATE_ENDED, "end of stream")
        except Exception as error:  # anything reading the input: report it, exit non-zero
            self.exit_code = 1
            self.get_logger().error(f"replay of {self.source.path} failed: {error}")
            self._finish(ReplayStatus.STATE_FAILED, str(error))

    def _wait_for_subscribers(self) -> None:
        """Lockstep: wait for the image subscribers and for someone publishing acknowledgements,
        so frame 0 is neither lost nor waits for an ack that cannot come."""
        if not self.params["lockstep"]:
            return
        wanted = self.params["wait_for_subscribers"]
        ack_topic = self.params["ack_topic"]

        def ready() -> bool:
            return (
                self.image_pub.get_subscription_count() >= wanted
                and self.count_publishers(ack_topic) > 0
            )

        if not ready():
            self.get_logger().info(
                f"lockstep: waiting for {wanted} subscriber(s) of scene/image_raw and a publisher "
                f"of {ack_topic}"
            )
        while not self._stop.is_set() and not ready():
            time.sleep(0.02)
        time.sleep(0.2)  # let the acknowledgement publisher finish matching our subscription

    def _play_once(self, start: int, end: int | None) -> None:
        started_wall = time.monotonic()
        first_stamp: int | None = None
        # Stamps keep increasing across loops: the next loop starts one frame after the last stamp.
        loop_offset = (
            stamp_to_ns(self.status.header.stamp) + round(1e9 / self.source.fps)
            if self.status.frames_published
            else 0
        )
        for frame in prefetched(self.source.frames(start, end), self._stop):
            if self._stop.is_set():
                return
            stamp = frame.stamp_ns + loop_offset
            first_stamp = stamp if first_stamp is None else first_stamp
            self._pace(stamp - first_stamp, started_wall)
            self._publish(frame, stamp)
            if self.params["lockstep"]:
                self._wait_for_ack(stamp)

    def _pace(self, since_first_ns: int, started_wall: float) -> None:
        rate = self.params["rate"]
        if rate <= 0:
            return
        delay = since_first_ns / 1e9 / rate - (time.monotonic() - started_wall)
        if delay > 0:
            self._stop.wait(delay)

    def _publish(self, frame: Frame, stamp_ns: int) -> None:
        stamp = ns_to_stamp(stamp_ns)
        if self.clock_pub is not None:
            self.clock_pub.publish(Clock(clock=stamp))
        image = frame.image
        if self.params["encoding"] == "mono8":
            import cv2

            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        frame_id = self.params["frame_id"]
        height, width = image.shape[:2]
        focal = self.params["focal_length"] or float(width)
        self.last_sent = (
            camera_info(width, height, focal, focal, width / 2, height / 2, stamp, frame_id),
            array_to_image(image, self.params["encoding"], stamp, frame_id),
        )
        self.info_pub.publish(self.last_sent[0])
        self.image_pub.publish(self.last_sent[1])
        self.status.header.stamp = stamp
        self.status.header.frame_id = frame_id
        self.status.frame_index = frame.index
        self.status.frames_published += 1
        self._note_skipped()
        self.status_pub.publish(self.status)

    def _note_skipped(self) -> None:
        if self.source.skipped > self.status.frames_skipped:
            self.get_logger().warning(
                f"skipped {self.source.skipped - self.status.frames_skipped} undecodable frame(s) of "
                f"{self.source.path} (total {self.source.skipped})"
            )
            self.status.frames_skipped = self.source.skipped

    def _wait_for_ack(self, stamp_ns: int) -> None:
        """Until frame `stamp_ns` is acknowledged, or the timeout. Halfway through, the frame is
        sent once more: a frame published while a subscriber was still completing discovery can
        be lost, and every node drops the duplicate of a frame it did get."""
        timeout = self.params["lockstep_timeout"]
        deadline = time.monotonic() + timeout
        resend_at = time.monotonic() + timeout / 2
        while self.acked_ns < stamp_ns and not self._stop.is_set():
            if resend_at is not None and time.monotonic() >= resend_at:
                resend_at = None
                self.info_pub.publish(self.last_sent[0])
                self.image_pub.publish(self.last_sent[1])
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self.status.lockstep_timeouts += 1
                self.get_logger().warning(
                    f"no acknowledgement of frame {self.status.frame_index} on "
                    f"{self.params['ack_topic']} within {self.params['lockstep_timeout']} s; going on",
                    throttle_duration_sec=5.0,
                )
                return
            self.ack_event.clear()
            if self.acked_ns < stamp_ns:
                self.ack_event.wait(remaining if resend_at is None else min(remaining, timeout / 2))

    def _finish(self, state: int, message: str) -> None:
        self._note_skipped()
        self.status.state = state
        self.status.message = message
        self.status_pub.publish(self.status)
        self.status_pub.wait_for_all_acked(rclpy.duration.Duration(seconds=1.0))
        self.get_logger().info(
            f"{message}: {self.status.frames_published} frames published, "
            f"{self.status.frames_skipped} skipped, {self.status.lockstep_timeouts} lockstep timeouts"
        )
        if not self.params["loop"] or state == ReplayStatus.STATE_FAILED or self._stop.is_set():
            self.context.try_shutdown()


def prefetched(frames: Iterator[Frame], stop: threading.Event, depth: int = 3) -> Iterator[Frame]:
    """`frames`, decoded ahead in a thread, so decoding frame n+1 overlaps waiting for frame n's
    acknowledgement (decoding a 768x576 frame takes a few ms)."""
    queue: Queue = Queue(maxsize=depth)
    done = object()

    def read() -> None:
        try:
            for frame in frames:
                while not stop.is_set():
                    try:
                        queue.put(frame, timeout=0.1)
                        break
                    except Full:
                        continue
                if stop.is_set():
                    return
            queue.put(done)
        except Exception as error:  # re-raised in the consumer, where the replay reports it
            queue.put(error)

    threading.Thread(target=read, daemon=True).start()
    while True:
        item = queue.get()
        if item is done:
            return
        if isinstance(item, Exception):
            raise item
        yield item


def main(args: list[str] | None = None) -> int:
    return run_node(VideoSourceNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
