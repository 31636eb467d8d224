"""Recorded frames to replay as a camera stream (no rclpy): video files, image folders, rosbag2.

`open_source(path)` picks the reader from what `path` is:
- a rosbag2 directory (with metadata.yaml), or its .mcap / .db3 file: the bag's Image or
  CompressedImage topic, stamped with the messages' header stamps (the recording time if zero);
- any other directory: its images in natural order ("2.png" before "10.png"), frame i stamped i / fps;
- any other file: a video OpenCV reads (avi, mp4, mkv...), frame i stamped i / fps.

Problems with the input as a whole raise SourceError with a message naming the path. A frame that
cannot be decoded mid-stream is skipped and counted in `skipped` (the caller warns).
"""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp"}
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
DEFAULT_FPS = 10.0
MAX_CONSECUTIVE_FAILURES = 25  # undecodable video frames in a row taken as the end of the file


class SourceError(RuntimeError):
    """The input cannot be replayed; the message says which path and why."""


@dataclass(frozen=True)
class Frame:
    index: int  # position in the input, from 0
    stamp_ns: int
    image: np.ndarray  # (H, W, 3) uint8 BGR


def frame_stamp_ns(index: int, fps: float) -> int:
    """Stamp of frame `index` of a recording at `fps` (frame 0 at t = 0)."""
    return round(index * 1e9 / fps)


def natural_key(name: str) -> list:
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


class FrameSource(ABC):
    """Base of the readers: `frames(start, end)` yields the frames with index in [start, end)."""

    path: Path
    fps: float
    total: int  # frames in the input, 0 when unknown
    skipped: int  # frames that could not be decoded so far
    lost: int = 0  # frames the input announces but that could not be reached
    end_note: str = ""  # why the stream ended early, if it did

    @abstractmethod
    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        """The decodable frames with index in [start, end), in order."""

    def describe(self) -> str:
        return f"{self.path} ({self.total or 'unknown number of'} frames at {self.fps:g} fps)"


class VideoFileSource(FrameSource):
    def __init__(self, path: Path, fps: float = 0.0) -> None:
        self.path = path
        capture = cv2.VideoCapture(str(path))
        if not capture.isOpened():
            raise SourceError(f"{path}: not a video OpenCV can read (unknown or unreadable format)")
        ok, _ = capture.read()
        capture.release()
        if not ok:
            raise SourceError(f"{path}: the video has no readable frames")
        probe = cv2.VideoCapture(str(path))
        self.fps = fps or probe.get(cv2.CAP_PROP_FPS) or DEFAULT_FPS
        self.total = max(0, int(probe.get(cv2.CAP_PROP_FRAME_COUNT)))
        probe.release()
        self.skipped = 0

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        capture = cv2.VideoCapture(str(self.path))
        index, failures = 0, 0
        try:
            while end is None or index < end:
                if index < start:
                    ok = capture.grab()  # decode-free skip keeps frame indices exact
                    image = None
                else:
                    ok, image = capture.read()
                if not ok:
                    if self.total and index < self.total and failures < MAX_CONSECUTIVE_FAILURES:
                        failures += 1
                        self.skipped += index >= start
                        index += 1
                        continue
                    return
                failures = 0
                if image is not None:
                    yield Frame(index, frame_stamp_ns(index, self.fps), image)
                index += 1
        finally:
            capture.release()


class ImageFolderSource(FrameSource):
    def __init__(self, path: Path, fps: float = 0.0) -> None:
        self.path = path
        self.files = sorted(
            (p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file()),
            key=lambda p: natural_key(p.name),
        )
        if not self.files:
            raise SourceError(
                f"{path}: no images ({', '.join(sorted(IMAGE_SUFFIXES))}) in the folder"
            )
        self.fps = fps or DEFAULT_FPS
        self.total = len(self.files)
        self.skipped = 0

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        for index in range(start, min(end or self.total, self.total)):
            image = cv2.imread(str(self.files[index]), cv2.IMREAD_COLOR)
            if image is None:
                self.skipped += 1
                continue
            yield Frame(index, frame_stamp_ns(index, self.fps), image)


class BagSource(FrameSource):
    def __init__(self, path: Path, topic: str = "") -> None:
        from rosbags.rosbag2 import Reader

        self.path = path
        try:
            with Reader(path) as reader:
                candidates = [c for c in reader.connections if c.msgtype in IMAGE_TYPES]
                duration = reader.duration
        except Exception as error:  # rosbags raises several types for unreadable bags
            raise SourceError(f"{path}: not a readable rosbag2 ({error})") from error
        if topic:
            candidates = [c for c in candidates if c.topic == topic]
        if not candidates:
            missing = f"no image topic {topic}" if topic else "no Image or CompressedImage topic"
            raise SourceError(f"{path}: the bag has {missing}")
        self.topic = candidates[0].topic
        self.total = sum(c.msgcount for c in candidates if c.topic == self.topic)
        if self.total == 0:
            raise SourceError(f"{path}: topic {self.topic} has no messages")
        self.fps = (
            (self.total - 1) / (duration / 1e9) if self.total > 1 and duration > 0 else DEFAULT_FPS
        )
        self.skipped = 0

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        from rosbags.rosbag2 import Reader

        from tracker_ptz_sim.recording import typestore

        store = typestore()
        with Reader(self.path) as reader:
            connections = [c for c in reader.connections if c.topic == self.topic]
            for index, (connection, timestamp, data) in enumerate(
                reader.messages(connections=connections)
            ):
                if index < start:
                    continue
                if end is not None and index >= end:
                    return
                try:
                    msg = store.deserialize_cdr(data, connection.msgtype)
                    image = decode_image_message(msg, connection.msgtype)
                except (ValueError, cv2.error, RuntimeError):
                    image = None
                if image is None:
                    self.skipped += 1
                    continue
                stamp = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
                yield Frame(index, stamp or timestamp, image)


def decode_image_message(msg: object, msgtype: str) -> np.ndarray | None:
    """BGR pixels of a deserialized Image (8-bit mono/colour encodings) or CompressedImage."""
    if msgtype.endswith("CompressedImage"):
        return cv2.imdecode(np.asarray(msg.data, dtype=np.uint8), cv2.IMREAD_COLOR)
    conversions = {
        "bgr8": (3, None),
        "rgb8": (3, cv2.COLOR_RGB2BGR),
        "mono8": (1, cv2.COLOR_GRAY2BGR),
        "bgra8": (4, cv2.COLOR_BGRA2BGR),
        "rgba8": (4, cv2.COLOR_RGBA2BGR),
    }
    if msg.encoding not in conversions:
        raise ValueError(f"unsupported image encoding '{msg.encoding}'")
    channels, code = conversions[msg.encoding]
    rows = np.asarray(msg.data, dtype=np.uint8)[: msg.step * msg.height].reshape(
        msg.height, msg.step
    )
    pixels = rows[:, : msg.width * channels].reshape(msg.height, msg.width, channels)
    return np.ascontiguousarray(pixels) if code is None else cv2.cvtColor(pixels, code)


def open_source(path: str | Path, fps: float = 0.0, bag_topic: str = "") -> FrameSource:
    """The reader for `path` (see the module docstring). `fps` overrides the stamps' frame rate
    for videos and folders (0 = the video's own, or 10 for folders)."""
    path = Path(path).expanduser()
    if not str(path):
        raise SourceError("no input: set the 'path' parameter to a video, image folder or rosbag2")
    if not path.exists():
        raise SourceError(f"{path}: no such file or directory")
    if (
        path.is_file()
        and path.suffix in (".mcap", ".db3")
        and (path.parent / "metadata.yaml").exists()
    ):
        path = path.parent
    if path.is_dir():
        if (path / "metadata.yaml").exists():
            return BagSource(path, bag_topic)
        return ImageFolderSource(path, fps)
    try:
        with path.open("rb"):
            pass
    except OSError as error:
        raise SourceError(f"{path}: cannot be read ({error.strerror})") from error
    return VideoFileSource(path, fps)
