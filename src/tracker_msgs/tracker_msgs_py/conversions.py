"""Conversions between ROS messages and plain Python / NumPy values, and the suite's QoS profiles.

Imports message types and rclpy.qos only; no node logic lives here.
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image

from tracker_msgs.msg import Rect as RectMsg
from tracker_msgs_py.geometry import Rect

#: Encodings the suite reads and writes: number of channels of each.
SUPPORTED_ENCODINGS: dict[str, int] = {"mono8": 1, "bgr8": 3, "rgb8": 3}

NS_PER_S = 1_000_000_000


class UnsupportedEncodingError(ValueError):
    """An Image whose encoding (or layout) the suite cannot read; `cause` names the kind of
    problem in a few words (one warning per cause, see tracker_msgs_py.problems)."""

    def __init__(self, message: str, cause: str) -> None:
        super().__init__(message)
        self.cause = cause


def image_qos(reliable: bool = False, depth: int | None = None) -> QoSProfile:
    """Sensor-data QoS for image streams (best effort, keep last 5), or reliable for lockstep
    replays, with a deeper history (30) so a slower reader such as a recorder loses nothing."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth or (30 if reliable else 5),
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
    )


def stamp_to_ns(stamp: Time) -> int:
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def ns_to_stamp(ns: int) -> Time:
    if ns < 0:
        raise ValueError(f"negative stamp {ns} ns")
    return Time(sec=int(ns // NS_PER_S), nanosec=int(ns % NS_PER_S))


def stamp_to_sec(stamp: Time) -> float:
    return stamp_to_ns(stamp) / NS_PER_S


def image_to_array(msg: Image) -> np.ndarray:
    """The pixels of a mono8/bgr8/rgb8 Image as an (H, W) or (H, W, 3) uint8 array (a view if possible).

    Raises UnsupportedEncodingError, naming the encoding, for anything else or for a malformed message.
    """
    channels = SUPPORTED_ENCODINGS.get(msg.encoding)
    if channels is None:
        raise UnsupportedEncodingError(
            f"unsupported image encoding '{msg.encoding}' (supported: "
            f"{', '.join(SUPPORTED_ENCODINGS)})",
            f"unsupported encoding '{msg.encoding}'",
        )
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    row_bytes = width * channels
    layout = f"{msg.encoding} image {width}x{height}, step {step}, {len(msg.data)} bytes"
    if height == 0 or width == 0:
        raise UnsupportedEncodingError(f"empty {layout}", "empty image")
    if step < row_bytes:
        raise UnsupportedEncodingError(
            f"malformed {layout}: the step is shorter than a row ({row_bytes} bytes)",
            "image step shorter than a row",
        )
    if len(msg.data) < step * height:
        raise UnsupportedEncodingError(
            f"malformed {layout}: fewer bytes than step x height ({step * height})",
            "image data shorter than step x height",
        )
    rows = np.frombuffer(msg.data, dtype=np.uint8, count=step * height).reshape(height, step)
    pixels = rows[:, :row_bytes]
    return pixels.reshape(height, width) if channels == 1 else pixels.reshape(height, width, 3)


def image_to_bgr(msg: Image) -> np.ndarray:
    """The image as BGR (H, W, 3) uint8; mono8 is replicated into three channels."""
    pixels = image_to_array(msg)
    if msg.encoding == "rgb8":
        return np.ascontiguousarray(pixels[:, :, ::-1])
    if msg.encoding == "mono8":
        return np.repeat(pixels[:, :, None], 3, axis=2)
    return pixels


def image_to_gray(msg: Image) -> np.ndarray:
    """The image as (H, W) uint8 luma, with the seed's weights 0.2989 R + 0.5870 G + 0.1140 B."""
    pixels = image_to_array(msg)
    if msg.encoding == "mono8":
        return pixels
    import cv2  # local import: keeps this module light for nodes that never convert colour

    code = cv2.COLOR_RGB2GRAY if msg.encoding == "rgb8" else cv2.COLOR_BGR2GRAY
    return cv2.cvtColor(np.ascontiguousarray(pixels), code)


def array_to_image(pixels: np.ndarray, encoding: str, stamp: Time, frame_id: str) -> Image:
    """An Image message holding `pixels` ((H, W) for mono8, (H, W, 3) for bgr8/rgb8, uint8)."""
    channels = SUPPORTED_ENCODINGS.get(encoding)
    if channels is None:
        raise UnsupportedEncodingError(
            f"cannot publish encoding '{encoding}'", f"unsupported encoding '{encoding}'"
        )
    expected_ndim = 2 if channels == 1 else 3
    if pixels.dtype != np.uint8 or pixels.ndim != expected_ndim:
        raise ValueError(
            f"{encoding} needs a uint8 array of {expected_ndim} dims, got "
            f"{pixels.dtype} {pixels.shape}"
        )
    msg = Image()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(pixels.shape[0]), int(pixels.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = msg.width * channels
    msg.data = np.ascontiguousarray(pixels).tobytes()
    return msg


def rect_to_msg(rect: Rect) -> RectMsg:
    return RectMsg(
        x=float(rect.x), y=float(rect.y), width=float(rect.width), height=float(rect.height)
    )


def msg_to_rect(msg: RectMsg) -> Rect:
    values = (msg.x, msg.y, msg.width, msg.height)
    if not all(math.isfinite(v) for v in values) or msg.width < 0 or msg.height < 0:
        raise ValueError(f"invalid rectangle {values}")
    return Rect(*values)


def msg_to_window(msg: RectMsg) -> Rect:
    """A camera window (PtzState.window): a finite rectangle of positive size, else ValueError."""
    window = msg_to_rect(msg)
    if window.width <= 0 or window.height <= 0:
        raise ValueError(f"empty rectangle {(window.x, window.y, window.width, window.height)}")
    return window


def camera_info(
    width: int,
    height: int,
    fx: float,
    fy: float,
    cx: float,
    cy: float,
    stamp: Time,
    frame_id: str,
) -> CameraInfo:
    """A CameraInfo for an undistorted pinhole camera (plumb_bob model with zero distortion)."""
    info = CameraInfo()
    info.header.stamp = stamp
    info.header.frame_id = frame_id
    info.width, info.height = int(width), int(height)
    info.distortion_model = "plumb_bob"
    info.d = [0.0] * 5
    info.k = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
    info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    info.p = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return info
