"""Recorded frames to replay as a camera stream (no rclpy): video files, image folders, rosbag2;
and live streams (`live_stream`: rtsp://, http(s)://, /dev/videoN).

`open_source(path)` picks the reader from what `path` is:
- a rosbag2 directory (with metadata.yaml), or its .mcap / .db3 file: the bag's Image or
  CompressedImage topic, stamped with the messages' header stamps (the recording time if zero);
- any other directory: its images in natural order ("2.png" before "10.png"), frame i stamped i / fps;
- any other file: a video OpenCV reads (avi, mp4, mkv...), frame i stamped i / fps.

Problems with the input as a whole raise SourceError with a message naming the path. A frame that
cannot be decoded mid-stream is skipped and counted in `skipped`, the reason in `skip_cause` when
the reader knows it (the caller warns); later frames keep their index. Frames the input announces
but does not hold (a truncated video) are counted in `lost`, and `end_note` says why the stream
ended early. `note` is a choice made for the user that they may want to change (a bag's first
image topic of several), warned at the start.
"""

from __future__ import annotations

import contextlib
import os
import re
import struct
import threading
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from tracker_msgs_py.codec import (
    IMAGE_TYPES,
    NS_PER_S,
    decode_image,
    frame_stamp_ns,
    header_stamp_ns,
    stamp_to_ns,
    typestore,
)

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp"}
DEFAULT_FPS = 10.0
STAMPS_FOR_RATE = 30  # header stamps a bag's frame rate is read from
CAPTURE_OPTIONS = "OPENCV_FFMPEG_CAPTURE_OPTIONS"  # FFmpeg options of the captures OpenCV opens
_OPTIONS_LOCK = threading.Lock()


class SourceError(RuntimeError):
    """The input cannot be replayed; the message says which path and why."""


@dataclass(frozen=True)
class Frame:
    index: int  # position in the input, from 0
    stamp_ns: int
    image: np.ndarray  # (H, W, 3) uint8 BGR


def natural_key(name: str) -> list:
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


class FrameSource(ABC):
    """Base of the readers: `frames(start, end)` yields the frames with index in [start, end)."""

    path: Path
    fps: float
    total: int  # frames in the input, 0 when unknown
    skipped: int  # frames of [start, end) held but not decodable, over all passes so far
    skip_cause: str = ""  # why the latest skipped frame could not be decoded, when known
    lost: int = 0  # frames of [start, end) announced but not held (the last pass that missed any)
    end_note: str = ""  # why the stream ended before the announced end, if it did
    note: str = ""  # a choice made for the user that they may not want (warned at the start)
    live: bool = False  # a camera stream: frames come as they arrive, newest first, never ending

    @abstractmethod
    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        """The decodable frames with index in [start, end), in order."""

    def describe(self) -> str:
        return f"{self.path} ({self.total or 'unknown number of'} frames at {self.fps:g} fps)"

    @property
    def label(self) -> str:
        """The input's name in logs and status (a path, or a stream URL without its password)."""
        return str(self.path)

    def close(self) -> None:  # noqa: B027 (a recording holds nothing open between passes)
        """Release what the reader holds open (a live stream's connection); frames() ends."""


class VideoFileSource(FrameSource):
    """A video file read with OpenCV. A frame that cannot be decoded costs only itself: the reader
    goes on with the next one, and every frame keeps its position in the file as its index."""

    def __init__(self, path: Path, fps: float = 0.0) -> None:
        self.path = path
        self.index_order = container_kind(path) == "AVI"
        self.packets: int | None = None  # frames the file holds, counted on the first failed read
        capture = open_capture(path, self.index_order)
        try:
            if not capture.isOpened():
                raise SourceError(f"{path}: {unreadable_cause(path)}")
            self.fps = fps or capture.get(cv2.CAP_PROP_FPS) or DEFAULT_FPS
            self.total = max(0, int(capture.get(cv2.CAP_PROP_FRAME_COUNT)))
            if not capture.read()[0]:
                cut = " (the file looks truncated)" if looks_truncated(path) else ""
                raise SourceError(f"{path}: the video has no readable frames{cut}")
        finally:
            capture.release()
        self.skipped = 0

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        capture = open_capture(self.path, self.index_order)
        index = 0
        try:
            while end is None or index < end:
                if index < start:
                    ok, image = capture.grab(), None  # skipped frames are not converted
                else:
                    ok, image = capture.read()
                if ok:
                    if image is not None:
                        yield Frame(index, frame_stamp_ns(index, self.fps), image)
                elif self._holds(index):
                    self.skipped += index >= start  # the next read goes on with frame index + 1
                else:
                    self._note_end(index, start, end)
                    return
                index += 1
        finally:
            capture.release()

    def _holds(self, index: int) -> bool:
        """After a failed read of frame `index`: whether the file holds it (damaged: skip it) rather
        than ending before it. A failed read consumes one packet (measured with FFmpeg on AVI read
        in index order and on MP4), so counting the packets once tells damage from the end."""
        if index >= self.total:
            return False
        if self.packets is None:
            self.packets = count_packets(self.path, self.index_order, self.total)
        return index < self.packets

    def _note_end(self, index: int, start: int, end: int | None) -> None:
        """The data ends at frame `index`: record the announced frames of [start, end) after it."""
        last = self.total if end is None else min(end, self.total)
        lost = last - max(index, start)
        if lost <= 0:
            return
        self.lost = lost
        why = "the file looks truncated" if looks_truncated(self.path) else "the file holds no more"
        self.end_note = (
            f"the video ends at frame {index} of {self.total}: {lost} frame{'s' * (lost != 1)} "
            f"could not be read ({why})"
        )


def video_frames(path: Path) -> Iterator[np.ndarray]:
    """The decodable frames (BGR) of a video file, in order (`VideoFileSource`)."""
    return (frame.image for frame in VideoFileSource(Path(path)).frames())


@contextlib.contextmanager
def capture_options(*options: str) -> Iterator[None]:
    """FFmpeg options ("name;value") for the captures OpenCV opens inside the block.

    OpenCV takes FFmpeg's options only from an environment variable, read when a capture is
    opened; it is restored at once (another thread opening a capture meanwhile gets them too,
    which the options used here only ever change for the inputs they are meant for)."""
    if not options:
        yield
        return
    with _OPTIONS_LOCK:
        saved = os.environ.get(CAPTURE_OPTIONS)
        os.environ[CAPTURE_OPTIONS] = "|".join(filter(None, (saved, *options)))
        try:
            yield
        finally:
            if saved is None:
                del os.environ[CAPTURE_OPTIONS]
            else:
                os.environ[CAPTURE_OPTIONS] = saved


def open_capture(path: Path, index_order: bool) -> cv2.VideoCapture:
    """OpenCV's reader of `path`; `index_order` makes FFmpeg read an AVI in its index's order.

    Read front to back, an AVI whose chunk headers are damaged is resynchronised on the next
    intact chunk without a word: the frames in between vanish and every later frame comes out
    under a smaller index. Read in index order (demuxer flag sortdts), each damaged frame is one
    failed read instead."""
    with capture_options(*(("fflags;+sortdts",) if index_order else ())):
        return cv2.VideoCapture(str(path))


def count_packets(path: Path, index_order: bool, total: int) -> int:
    """Video packets (frames) the demuxer finds in `path`, without decoding them; `total` when
    the backend cannot hand out raw packets."""
    capture = open_capture(path, index_order)
    try:
        if not capture.set(cv2.CAP_PROP_FORMAT, -1):  # raw packets: FFmpeg backend only
            return total
        count = 0
        while capture.grab():
            count += 1
        return count
    finally:
        capture.release()


def container_kind(path: Path) -> str:
    """The container of `path` from its first bytes: AVI, MP4 (ISO-BMFF: MP4, MOV...), Matroska
    (MKV, WebM), or "" when none of these."""
    with path.open("rb") as file:
        head = file.read(12)
    if head[:4] == b"RIFF" and head[8:12] == b"AVI ":
        return "AVI"
    if head[4:8] == b"ftyp":
        return "MP4"
    if head[:4] == b"\x1a\x45\xdf\xa3":
        return "Matroska"
    return ""


def top_level_boxes(path: Path) -> Iterator[tuple[bytes, int, int]]:
    """(type, offset, length) of the top-level boxes of an ISO-BMFF file or chunks of an AVI (RIFF)
    file, as their headers announce them; stops at a header that makes no sense."""
    riff = container_kind(path) == "AVI"
    size = path.stat().st_size
    offset = 0
    with path.open("rb") as file:
        while offset + 8 <= size:
            file.seek(offset)
            header = file.read(16)
            if riff:
                kind, length = struct.unpack("<4sI", header[:8])
                length += 8 + (length & 1)  # header, data, pad byte
            else:
                length, kind = struct.unpack(">I4s", header[:8])
                if length == 1 and len(header) == 16:  # 64-bit length after the type
                    length = struct.unpack(">Q", header[8:])[0]
                elif length == 0:  # the box runs to the end of the file
                    length = size - offset
            if length < 8:
                return
            yield kind, offset, length
            offset += length


def looks_truncated(path: Path) -> bool:
    """Whether the last top-level box or chunk of an AVI or ISO-BMFF file runs past its end."""
    if container_kind(path) not in ("AVI", "MP4"):
        return False
    size = path.stat().st_size
    return any(offset + length > size for _, offset, length in top_level_boxes(path))


def unreadable_cause(path: Path) -> str:
    """Why OpenCV cannot open `path`, as far as its first bytes and top-level boxes tell."""
    if path.stat().st_size == 0:
        return "the file is empty"
    kind = container_kind(path)
    if kind == "MP4" and all(box != b"moov" for box, _, _ in top_level_boxes(path)):
        name = "MOV" if path.suffix.lower() == ".mov" else "MP4"
        return (
            f"the {name} has no index ('moov' atom not found): the recording was not finalised "
            "(the recorder was stopped before closing the file) or the file was cut short. "
            "Remuxing cannot fix that; untrunc, given a complete recording from the same camera, "
            "can sometimes rebuild the index"
        )
    if kind:
        cut = ", and the file looks truncated" if looks_truncated(path) else ""
        return (
            f"not a video OpenCV can read: {'a' if kind == 'Matroska' else 'an'} {kind} file it "
            f"cannot open (damaged header, or a codec this OpenCV build lacks{cut})"
        )
    return "not a video OpenCV can read (not a video format it recognises)"


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
        if not fps:
            self.note = (
                f"{path}: a folder of images carries no frame rate: its frames are stamped at "
                f"{DEFAULT_FPS:g} fps (the fps parameter sets the camera's)"
            )
        self.total = len(self.files)
        self.skipped = 0

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        for index in range(start, min(end or self.total, self.total)):
            image = cv2.imread(str(self.files[index]), cv2.IMREAD_COLOR)
            if image is None:
                self.skipped += 1
                self.skip_cause = f"OpenCV cannot read {self.files[index].name}"
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
        others = sorted({c.topic for c in candidates} - {self.topic})
        if others:
            self.note = (
                f"{path}: the bag has more image topics than the one replayed, {self.topic}: "
                f"{', '.join(others)} (the bag_topic parameter chooses)"
            )
        self.total = sum(c.msgcount for c in candidates if c.topic == self.topic)
        if self.total == 0:
            raise SourceError(f"{path}: topic {self.topic} has no messages")
        recorded_rate = (self.total - 1) / (duration / NS_PER_S) if duration > 0 else 0.0
        try:
            stamp_rate = self._stamp_rate()
        except Exception:  # rosbags raises several types; a damaged message is frames()'s to report
            stamp_rate = None
        self.fps = stamp_rate or recorded_rate or DEFAULT_FPS
        self.skipped = 0

    def _stamp_rate(self, count: int = STAMPS_FOR_RATE) -> float | None:
        """Frames per second from the median gap between the first `count` header stamps (a bag
        recorded faster than real time, as a lockstep replay records, has its own time in them);
        None when they are unset."""
        from rosbags.rosbag2 import Reader

        stamps = []
        with Reader(self.path) as reader:
            connections = [c for c in reader.connections if c.topic == self.topic]
            for _, _, data in reader.messages(connections=connections):
                stamps.append(header_stamp_ns(data))
                if len(stamps) == count:
                    break
        gaps = np.diff(stamps)
        gaps = gaps[gaps > 0]
        return NS_PER_S / float(np.median(gaps)) if gaps.size else None

    def describe(self) -> str:
        return f"{self.path} topic {self.topic} ({self.total} frames at {self.fps:g} fps)"

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        from rosbags.rosbag2 import Reader

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
                msg: Any = None
                try:
                    msg = store.deserialize_cdr(data, connection.msgtype)
                    image = decode_image(msg)
                except (ValueError, cv2.error, RuntimeError) as error:
                    image, self.skip_cause = None, f"{self.topic}: {error}"
                if image is None:
                    self.skipped += 1
                    continue
                stamp = stamp_to_ns(msg.header.stamp)
                yield Frame(index, stamp or timestamp, image)


def open_source(path: str | Path, fps: float = 0.0, bag_topic: str = "") -> FrameSource:
    """The reader for `path` (see the module docstring). `fps` overrides the stamps' frame rate
    for videos and folders (0 = the video's own, or 10 for folders). Live streams are
    `live_stream.open_input`'s."""
    if not str(path).strip():  # Path("") would be the current directory
        raise SourceError(
            "no input given: the 'path' parameter is empty; it must name a video file, an image "
            "folder, a rosbag2 or a stream URL (rtsp://, http://, /dev/video0)"
        )
    path = Path(path).expanduser()
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
