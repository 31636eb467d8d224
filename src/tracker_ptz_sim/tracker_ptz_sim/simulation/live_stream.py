"""A live camera stream as a frame source (no rclpy): rtsp://, http(s):// (MJPEG), a V4L2 device.

`LiveStreamSource` reads the stream in its own thread, free-running, and keeps only the newest
frame: a graph slower than the camera gets the latest image, never a queue growing behind it, and
each frame replaced before it was taken is counted in `dropped`. Frames are stamped on arrival
(wall clock, nanoseconds since the epoch); where the stream carries its own presentation times
(RTSP, most containers) the stamps follow those from the first frame's arrival on, so network
jitter does not reach them, re-anchored whenever they drift from arrival by more than
`MAX_STAMP_DRIFT_NS`. When the stream dies (the server restarts, the network drops) the reader
reconnects with exponential backoff, forever, until stopped; every outage is one event. A URL or
device that does not open is diagnosed once in plain words (`stream_problem`: refused, unknown
host, wrong credentials, no such path) and `LiveStreamSource` raises SourceError when the
first connection fails, so a typo is a clear start-up failure, not an endless retry.
"""

from __future__ import annotations

import base64
import os
import re
import socket
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

import cv2
import numpy as np

from tracker_ptz_sim.simulation.frame_sources import (
    Frame,
    FrameSource,
    SourceError,
    capture_options,
    open_source,
)

STREAM_SCHEMES = ("rtsp", "rtsps", "rtmp", "http", "https", "udp", "tcp", "srt")
OPEN_TIMEOUT_S = 5.0  # FFmpeg's limit on opening the stream
READ_TIMEOUT_S = 5.0  # a stream that sends nothing for this long is dead
MAX_STAMP_DRIFT_NS = 1_000_000_000  # stream time this far from arrival: re-anchor on arrival
RECONNECT_FIRST_S = 0.5
RECONNECT_GROWTH = 1.5  # retries 0.5, 1.25, 2.4, 4.1 s... after a loss: a quick restart is caught
RECONNECT_MAX_S = 10.0
#: FFmpeg probes a network stream this long [us] before it hands out frames (its default took
#: 2 s per connect here, and handed over those 2 s of frames at once, old on arrival); RTSP
#: describes its streams in the SDP, and half a second holds a keyframe of a usual camera stream.
PROBE_US = 500_000
RTSP_PORT = 554
RTSP_TRANSPORTS = ("tcp", "udp", "auto")  # auto: FFmpeg's own choice, UDP first then TCP

EventSink = Callable[[str, str], None]  # (level "info" | "warning", message)


def is_device(path: str | Path) -> bool:
    """Whether `path` names a V4L2 capture device, /dev/videoN."""
    return re.fullmatch(r"/dev/video\d+", str(path)) is not None


def is_live_stream(path: str | Path) -> bool:
    """Whether `path` names a live stream (a URL of a streaming scheme, or /dev/videoN)."""
    return urlsplit(str(path)).scheme.lower() in STREAM_SCHEMES or is_device(path)


def ffmpeg_options(url: str, rtsp_transport: str) -> tuple[str, ...]:
    """FFmpeg's options for opening stream `url` ("name;value"): a short probe, and the RTSP
    transport of an RTSP URL."""
    if rtsp_transport not in RTSP_TRANSPORTS:
        raise ValueError(f"rtsp_transport must be one of {', '.join(RTSP_TRANSPORTS)}")
    probe = f"analyzeduration;{PROBE_US}"
    rtsp = urlsplit(url).scheme.lower() in ("rtsp", "rtsps")
    return (
        (probe, f"rtsp_transport;{rtsp_transport}")
        if rtsp and rtsp_transport != "auto"
        else (probe,)
    )


def redacted(url: str) -> str:
    """`url` with its password replaced by ***, for logs."""
    parts = urlsplit(url)
    if parts.password is None:
        return url
    host = parts.hostname or ""
    if parts.port:
        host = f"{host}:{parts.port}"
    return urlunsplit(parts._replace(netloc=f"{parts.username}:***@{host}"))


@dataclass
class _Slot:
    """The newest frame read, and the sequence number of the last one taken."""

    image: np.ndarray | None = None
    stamp_ns: int = 0
    sequence: int = 0  # frames read so far (this frame's number, from 1)
    taken: int = 0


class StreamClock:
    """Stamps of one connection's frames: arrival time, moved onto the stream's own timeline
    (`stream_ms`, < 0 when the stream has none) from the first frame on; stamps only increase.
    A stamp is never later than the frame's arrival (no frame is taken after it arrived): a frame
    that would be stamped so — it came sooner after the anchor than the stream's time says, or
    the server sent a burst ahead of time — becomes the new anchor, so the anchor settles on the
    frames that came quickest."""

    def __init__(self) -> None:
        self.anchor: tuple[int, float] | None = None  # (arrival ns, stream ms) of the anchor frame
        self.last_ns = 0

    def reconnected(self) -> None:
        self.anchor = None  # a new connection restarts the stream's timeline

    def stamp(self, arrival_ns: int, stream_ms: float) -> int:
        stamp = arrival_ns
        if stream_ms >= 0:
            if self.anchor is not None:
                stamp = self.anchor[0] + round((stream_ms - self.anchor[1]) * 1e6)
            late = arrival_ns - stamp > MAX_STAMP_DRIFT_NS
            if self.anchor is None or stamp > arrival_ns or late:
                self.anchor, stamp = (arrival_ns, stream_ms), arrival_ns
        stamp = max(stamp, self.last_ns + 1)
        self.last_ns = stamp
        return stamp


class LiveStreamSource(FrameSource):
    """The newest frames of a live stream; `frames()` runs until `close()` (see the module)."""

    live = True

    def __init__(
        self,
        url: str,
        on_event: EventSink | None = None,
        open_timeout_s: float = OPEN_TIMEOUT_S,
        read_timeout_s: float = READ_TIMEOUT_S,
        clock: Callable[[], int] = time.time_ns,
        rtsp_transport: str = "tcp",
    ) -> None:
        """`rtsp_transport` (RTSP URLs only): tcp, RTP interleaved on the RTSP connection, so a
        camera or server that goes away is noticed at once and no packet is lost on the way;
        udp; or auto."""
        ffmpeg_options(url, rtsp_transport)  # a bad transport fails here
        self.url = url
        self.rtsp_transport = rtsp_transport
        self.path = Path(self.label)  # a URL as a Path folds its "//": logs use `label`
        self.total = 0
        self.skipped = 0
        self.dropped = 0  # frames replaced by a newer one before they were taken
        self.reconnects = 0
        self.connected = True
        self.failure: Exception | None = None  # what ended the reader thread, if not close()
        self.fps = 0.0
        self.on_event = on_event or (lambda level, message: None)
        self.open_timeout_s = open_timeout_s
        self.read_timeout_s = read_timeout_s
        self.clock = clock
        self.stamps = StreamClock()
        self.slot = _Slot()
        self.changed = threading.Condition()
        self.closed = threading.Event()
        capture = self._open()
        if capture is None:
            raise SourceError(f"{self.label}: {stream_problem(url, open_timeout_s)}")
        self.fps = capture.get(cv2.CAP_PROP_FPS) or 0.0
        if self.fps > 1000:  # FFmpeg's "unknown" for some streams (90000, the RTP clock)
            self.fps = 0.0
        self.reader = threading.Thread(
            target=self._read_forever, args=(capture,), name="stream-reader", daemon=True
        )
        self.reader.start()

    @property
    def label(self) -> str:
        return redacted(self.url)

    def describe(self) -> str:
        rate = f"{self.fps:g} fps" if self.fps else "unknown frame rate"
        return f"live stream {self.label} ({rate}; newest frame wins, stamped on arrival)"

    def frames(self, start: int = 0, end: int | None = None) -> Iterator[Frame]:
        """The newest frame each time the caller is ready for one, numbered from 0 as taken;
        `start` frames are read and dropped first, and it ends after frame `end` - 1."""
        index = 0
        while not self.closed.is_set() and (end is None or index < end):
            taken = self._take()
            if taken is None:
                continue
            image, stamp_ns = taken
            if index >= start:
                yield Frame(index, stamp_ns, image)
            index += 1
        if self.failure is not None:
            raise SourceError(f"{self.label}: the stream reader failed: {self.failure!r}")

    def close(self, timeout: float = 2.0) -> None:
        self.closed.set()
        with self.changed:
            self.changed.notify_all()
        self.reader.join(timeout)

    def _take(self, wait_s: float = 0.5) -> tuple[np.ndarray, int] | None:
        with self.changed:
            if self.slot.sequence == self.slot.taken:
                self.changed.wait(wait_s)
            slot = self.slot
            if slot.image is None or slot.sequence == slot.taken:
                return None
            self.dropped += slot.sequence - slot.taken - 1
            self.lost = self.dropped  # what a replay's status counts as frames not reached
            slot.taken = slot.sequence
            return slot.image, slot.stamp_ns

    def _open(self) -> cv2.VideoCapture | None:
        if is_device(self.url):
            capture = cv2.VideoCapture(self.url, cv2.CAP_V4L2)
        else:
            timeouts = [
                cv2.CAP_PROP_OPEN_TIMEOUT_MSEC,
                round(self.open_timeout_s * 1000),
                cv2.CAP_PROP_READ_TIMEOUT_MSEC,
                round(self.read_timeout_s * 1000),
            ]
            with capture_options(*ffmpeg_options(self.url, self.rtsp_transport)):
                capture = cv2.VideoCapture(self.url, cv2.CAP_FFMPEG, timeouts)
        if capture.isOpened():
            return capture
        capture.release()
        return None

    def _read_forever(self, capture: cv2.VideoCapture | None) -> None:
        """The reader thread: a failure of its own ends the stream, raised by `frames()`."""
        try:
            self._read_until_closed(capture)
        except Exception as error:
            self.failure = error
            self.closed.set()
            with self.changed:
                self.changed.notify_all()

    def _read_until_closed(self, capture: cv2.VideoCapture | None) -> None:
        backoff = RECONNECT_FIRST_S
        lost_at: float | None = None
        while not self.closed.is_set():
            if capture is None:
                capture = self._open()
                if capture is None:
                    self.closed.wait(backoff)
                    backoff = min(RECONNECT_GROWTH * backoff, RECONNECT_MAX_S)
                    continue
                self.reconnects += 1
                self.connected = True
                self.stamps.reconnected()
                outage = time.monotonic() - (lost_at or time.monotonic())
                self.on_event(
                    "info", f"{self.label}: stream back after {outage:.1f} s, reconnected"
                )
            ok, image = capture.read()
            if ok and image is not None:
                backoff, lost_at = RECONNECT_FIRST_S, None
                self._put(image, capture.get(cv2.CAP_PROP_POS_MSEC))
                continue
            capture.release()
            capture = None
            if not self.closed.is_set():
                self.connected = False
                lost_at = time.monotonic()
                self.on_event(
                    "warning",
                    f"{self.label}: stream lost ({stream_problem(self.url, 1.0)}); "
                    f"reconnecting after {RECONNECT_FIRST_S:g} s, then less often, "
                    f"up to every {RECONNECT_MAX_S:g} s",
                )
        if capture is not None:
            capture.release()

    def _put(self, image: np.ndarray, stream_ms: float) -> None:
        stamp = self.stamps.stamp(self.clock(), stream_ms if stream_ms > 0 else -1.0)
        with self.changed:
            self.slot.image, self.slot.stamp_ns = image, stamp
            self.slot.sequence += 1
            self.changed.notify_all()


def open_input(
    path: str | Path,
    fps: float = 0.0,
    bag_topic: str = "",
    on_event: EventSink | None = None,
    rtsp_transport: str = "tcp",
) -> FrameSource:
    """A live stream's reader for a stream URL or /dev/videoN, else `open_source`'s for a
    recording (`fps`, `bag_topic` are the recording's)."""
    if is_live_stream(path):
        return LiveStreamSource(str(path), on_event, rtsp_transport=rtsp_transport)
    return open_source(path, fps, bag_topic)


def stream_problem(url: str, timeout_s: float) -> str:
    """Why `url` gives no video, in plain words, as far as asking its server tells."""
    if is_device(url):
        if not os.path.exists(url):
            return "no such video device (is the camera plugged in? ls /dev/video*)"
        if not os.access(url, os.R_OK):
            return "no permission to read the device (add the user to the 'video' group)"
        return "the device does not deliver frames OpenCV can read (busy, or not a capture device)"
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if not parts.hostname:
        return "the URL names no host"
    if scheme in ("http", "https"):
        return _http_problem(url, timeout_s)
    if scheme == "rtsp":
        return _rtsp_problem(url, timeout_s)
    return "the stream does not open (FFmpeg cannot read it)"


def _connect_problem(host: str, port: int, timeout_s: float) -> str | None:
    try:
        socket.getaddrinfo(host, port)
    except socket.gaierror:
        return f"unknown host {host}"
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return None
    except ConnectionRefusedError:
        return f"connection refused by {host}:{port} (no server listening there)"
    except OSError as error:
        return f"cannot connect to {host}:{port} ({error.strerror or error})"


def _rtsp_problem(url: str, timeout_s: float) -> str:
    parts = urlsplit(url)
    host, port = parts.hostname or "", parts.port or RTSP_PORT
    problem = _connect_problem(host, port, timeout_s)
    if problem:
        return problem
    plain = urlunsplit(parts._replace(netloc=f"{host}:{port}"))
    request = f"DESCRIBE {plain} RTSP/1.0\r\nCSeq: 1\r\nAccept: application/sdp\r\n"
    if parts.username is not None:
        token = base64.b64encode(f"{parts.username}:{parts.password or ''}".encode()).decode()
        request += f"Authorization: Basic {token}\r\n"
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as connection:
            connection.sendall((request + "\r\n").encode())
            status = connection.recv(4096).decode(errors="replace").split("\r\n", 1)[0]
    except OSError as error:
        return f"the RTSP server at {host}:{port} did not answer ({error})"
    code = status.split()[1] if len(status.split()) > 1 else ""
    if code == "401":
        if parts.username is None:
            return "the camera needs credentials: rtsp://user:password@host/..."
        return "the camera refused the user name or password (401 Unauthorized)"
    if code == "404":
        return f"the server has no stream at {parts.path or '/'} (404 Not Found)"
    if code.startswith("2"):
        return "the server offers the stream but it does not play (codec or transport)"
    return f"the RTSP server answered '{status}'"


def _http_problem(url: str, timeout_s: float) -> str:
    parts = urlsplit(url)
    host = parts.hostname or ""
    port = parts.port or (443 if parts.scheme == "https" else 80)
    problem = _connect_problem(host, port, timeout_s)
    if problem:
        return problem
    try:
        with urllib.request.urlopen(url, timeout=timeout_s) as answer:
            kind = answer.headers.get("Content-Type", "unknown")
            return f"the server answers but not with a video stream OpenCV reads ({kind})"
    except urllib.error.HTTPError as error:
        if error.code == 401:
            return "the camera refused the credentials (401 Unauthorized)"
        return f"the server answered {error.code} {error.reason}"
    except (urllib.error.URLError, OSError) as error:
        return f"the server did not answer ({error})"
