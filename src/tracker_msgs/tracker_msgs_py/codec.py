"""The suite's one codec between messages and plain values, as cv_bridge is for C++ (no node logic).

- pixels: `image_to_array` reads an Image as it is laid out (mono8, bgr8, rgb8, bgra8, rgba8);
  `image_to_bgr` / `image_to_gray` also convert what camera drivers publish raw (the 8-bit Bayer
  mosaics, yuv422 / yuv422_yuy2); anything else raises `UnsupportedEncodingError`;
  `decode_image` also reads a CompressedImage, from rclpy or from a rosbags-deserialized message
  alike; `array_to_image` writes;
- stamps: `stamp_to_ns`, `ns_to_stamp`, `stamp_to_sec`, `frame_stamp_ns` (frame index at a rate);
- rectangles: `rect_to_msg`, `msg_to_rect`, `msg_to_window` (a camera window of positive size);
- values: `usable_value` -- finite and within `MAX_MESSAGE_VALUE`, the one rule every node applies
  to the numbers a message brings before they reach its state;
- `camera_info` for a pinhole camera, `image_qos` for image streams, `typestore` for rosbags.

Message classes and rclpy are imported where a function builds them, so the functional core
(frame readers, reports) decodes through this module without importing rclpy.
"""

from __future__ import annotations

import array
import math
import struct
from collections.abc import Sequence
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

from tracker_msgs_py.geometry import Rect

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time
    from rclpy.qos import QoSProfile
    from rosbags.typesys.store import Typestore
    from sensor_msgs.msg import CameraInfo, Image

    from tracker_msgs.msg import Rect as RectMsg

#: Encodings the suite reads and writes as they are laid out: number of channels of each.
SUPPORTED_ENCODINGS: dict[str, int] = {"mono8": 1, "bgr8": 3, "rgb8": 3, "bgra8": 4, "rgba8": 4}

#: Raw camera encodings `image_to_bgr` / `image_to_gray` convert (REP-104 / sensor_msgs names):
#: bytes per pixel and the name of OpenCV's conversion to BGR. OpenCV names a Bayer pattern by
#: the 2x2 block at the second row and column, so ROS's bayer_rggb8 is its BayerBG (as in
#: cv_bridge); yuv422 is UYVY byte order, yuv422_yuy2 YUYV.
CAMERA_ENCODINGS: dict[str, tuple[int, str]] = {
    "bayer_rggb8": (1, "COLOR_BayerBG2BGR"),
    "bayer_bggr8": (1, "COLOR_BayerRG2BGR"),
    "bayer_gbrg8": (1, "COLOR_BayerGR2BGR"),
    "bayer_grbg8": (1, "COLOR_BayerGB2BGR"),
    "yuv422": (2, "COLOR_YUV2BGR_UYVY"),
    "uyvy": (2, "COLOR_YUV2BGR_UYVY"),
    "yuv422_yuy2": (2, "COLOR_YUV2BGR_YUYV"),
    "yuyv": (2, "COLOR_YUV2BGR_YUYV"),
}

NS_PER_S = 1_000_000_000

#: rosbags type names of the messages `decode_image` reads.
IMAGE_TYPES = frozenset({"sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage"})


class UnsupportedEncodingError(ValueError):
    """An Image whose encoding (or layout) the suite cannot read; `cause` names the kind of
    problem in a few words (one warning per cause, see tracker_msgs_py.problems)."""

    def __init__(self, message: str, cause: str) -> None:
        super().__init__(message)
        self.cause = cause


def image_qos(reliable: bool = False, depth: int | None = None) -> QoSProfile:
    """Sensor-data QoS for image streams (best effort, keep last 5), or reliable for lockstep
    replays, with a deeper history (30) so a slower reader such as a recorder loses nothing."""
    return _keep_last(depth or (30 if reliable else 5), reliable)


RESULT_DEPTH = 200  # per-frame results: a recorder stalled ~20 s at 10 fps still loses nothing


def result_qos(late_joiners: bool = True) -> QoSProfile:
    """Reliable QoS for small per-frame results (detections, tracks, target, pan-tilt state).
    Keep-last history still drops a sample a slow reader has not yet acknowledged
    once `depth` newer ones are queued, so the depth covers a recorder that stalls on disk while
    the graph keeps running; the messages are small, so the memory is a few hundred kB.

    Publishers keep that history for late joiners too (transient local): a reader whose
    discovery completes after the first frames -- the recorder on a loaded machine, where a
    node's writer learnt of it only after publishing frame 1 -- still gets them when it asks
    (`late_joiners`). A node that acts on what it receives asks for `late_joiners=False`
    (volatile): restarted, it must not act on old messages."""
    return _keep_last(RESULT_DEPTH, reliable=True, durable=late_joiners)


COMMAND_DEPTH = 10  # commands kept for a reader that has not acknowledged them yet


def command_qos() -> QoSProfile:
    """QoS for motion commands (ptz/command, JointState commands): reliable, volatile, keep last
    COMMAND_DEPTH. A driver, bridge or recorder that starts late or restarts never receives
    commands published before it: acting on a stale command moves a camera nobody asked to move.
    A reader asking for transient local does not match (rclpy reports the incompatible QoS)."""
    return _keep_last(COMMAND_DEPTH, reliable=True)


def is_command_topic(name: str) -> bool:
    """Whether a topic carries motion commands (its last name ends in 'command': ptz/command,
    ptz/joint_command), which are published with `command_qos`."""
    return name.rstrip("/").rsplit("/", 1)[-1].endswith("command")


def _keep_last(depth: int, reliable: bool, durable: bool = False) -> QoSProfile:
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if durable else DurabilityPolicy.VOLATILE,
    )


MAX_MESSAGE_VALUE = 1e6  # px, px/s, rad, rad/s: beyond any scene or motion, a corrupt message


def usable_value(value: float) -> bool:
    """Whether a number a message brings is finite and within +-MAX_MESSAGE_VALUE."""
    return math.isfinite(value) and abs(value) <= MAX_MESSAGE_VALUE


def stamp_to_ns(stamp: Time) -> int:
    """Nanoseconds of a builtin_interfaces/Time (rclpy or rosbags message)."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def header_stamp_ns(cdr: bytes) -> int:
    """Nanoseconds of the header stamp of a serialized (CDR) message whose first field is a
    std_msgs/Header (Image, CompressedImage, CameraInfo...), read without deserializing it."""
    little = len(cdr) > 1 and cdr[1] & 1  # the encapsulation: CDR_LE or CDR_BE
    sec, nanosec = struct.unpack_from("<iI" if little else ">iI", cdr, 4)
    stamp_ns: int = sec * NS_PER_S + nanosec
    return stamp_ns


def joint_values(
    names: Sequence[str], values: Sequence[float], wanted: Sequence[str]
) -> tuple[float, ...] | None:
    """The `wanted` joints' entries of a JointState array (position, velocity...) by name; None
    when a joint is not named or the array has no entry for it."""
    names = list(names)
    try:
        return tuple(float(values[names.index(joint)]) for joint in wanted)
    except (ValueError, IndexError):
        return None


def ns_to_stamp(ns: int) -> Time:
    from builtin_interfaces.msg import Time

    if ns < 0:
        raise ValueError(f"negative stamp {ns} ns")
    return Time(sec=int(ns // NS_PER_S), nanosec=int(ns % NS_PER_S))


def stamp_to_sec(stamp: Time) -> float:
    return stamp_to_ns(stamp) / NS_PER_S


def frame_stamp_ns(index: int, fps: float) -> int:
    """Stamp of frame `index` of a recording at `fps` (frame 0 at t = 0)."""
    return round(index * NS_PER_S / fps)


def float64_sequence(values: np.ndarray) -> array.array:
    """A float64[] message field's value; array.array skips rclpy's per-element checks of a
    list."""
    sequence = array.array("d")
    sequence.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return sequence


def image_to_array(msg: Image) -> np.ndarray:
    """The pixels of a mono8/bgr8/rgb8 Image as an (H, W) or (H, W, 3) uint8 array (a view if possible).

    Raises UnsupportedEncodingError, naming the encoding, for anything else or for a malformed message.
    """
    channels = SUPPORTED_ENCODINGS.get(msg.encoding)
    if channels is None:
        raise _unsupported(msg.encoding)
    pixels = _rows(msg, channels)
    if channels == 1:
        return pixels
    return pixels.reshape(pixels.shape[0], -1, channels)


def _unsupported(encoding: str) -> UnsupportedEncodingError:
    readable = ", ".join([*SUPPORTED_ENCODINGS, *CAMERA_ENCODINGS])
    return UnsupportedEncodingError(
        f"unsupported image encoding '{encoding}' (supported: {readable})",
        f"unsupported encoding '{encoding}'",
    )


def _rows(msg: Image, bytes_per_pixel: int) -> np.ndarray:
    """The image's rows (H, W x bytes_per_pixel) uint8 without their padding, checked against
    its height, width, step and data length."""
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    row_bytes = width * bytes_per_pixel
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
    return rows[:, :row_bytes]


def _camera_to_bgr(msg: Image) -> np.ndarray:
    """A raw camera encoding (CAMERA_ENCODINGS) converted to BGR (H, W, 3) uint8."""
    import cv2  # local import: keeps this module light for nodes that never convert colour

    bytes_per_pixel, conversion = CAMERA_ENCODINGS[msg.encoding]
    if bytes_per_pixel == 2 and int(msg.width) % 2:
        raise UnsupportedEncodingError(
            f"malformed {msg.encoding} image: odd width {msg.width} (pixels come in pairs)",
            "odd width of a yuv422 image",
        )
    rows = _rows(msg, bytes_per_pixel)
    pixels = rows if bytes_per_pixel == 1 else rows.reshape(rows.shape[0], -1, bytes_per_pixel)
    return cv2.cvtColor(np.ascontiguousarray(pixels), getattr(cv2, conversion))


def image_to_bgr(msg: Image) -> np.ndarray:
    """The image as BGR (H, W, 3) uint8; mono8 is replicated into three channels, alpha dropped,
    Bayer mosaics demosaiced and yuv422 converted."""
    if msg.encoding in CAMERA_ENCODINGS:
        return _camera_to_bgr(msg)
    pixels = image_to_array(msg)
    if msg.encoding in ("rgb8", "rgba8"):
        return np.ascontiguousarray(pixels[:, :, 2::-1])
    if msg.encoding == "mono8":
        return np.repeat(pixels[:, :, None], 3, axis=2)
    return pixels if msg.encoding == "bgr8" else np.ascontiguousarray(pixels[:, :, :3])


def compressed_to_bgr(msg: Any) -> np.ndarray:
    """A sensor_msgs/CompressedImage (jpeg, png: what image_transport's compressed plug-in and
    camera drivers such as Axis's publish) as BGR (H, W, 3) uint8; raises
    UnsupportedEncodingError when its data does not decode."""
    import cv2  # local import, as in image_to_gray

    data = np.frombuffer(bytes(msg.data), np.uint8)
    pixels = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if pixels is None:
        raise UnsupportedEncodingError(
            f"a CompressedImage (format '{msg.format}', {data.size} bytes) that does not decode "
            "as an image",
            "undecodable compressed image",
        )
    return pixels


def image_to_gray(msg: Image) -> np.ndarray:
    """The image as (H, W) uint8 luma, with the seed's weights 0.2989 R + 0.5870 G + 0.1140 B."""
    if msg.encoding in CAMERA_ENCODINGS:
        pixels, encoding = _camera_to_bgr(msg), "bgr8"
    else:
        pixels, encoding = image_to_array(msg), msg.encoding
    if encoding == "mono8":
        return pixels
    import cv2  # local import: keeps this module light for nodes that never convert colour

    code = {
        "rgb8": cv2.COLOR_RGB2GRAY,
        "bgr8": cv2.COLOR_BGR2GRAY,
        "rgba8": cv2.COLOR_RGBA2GRAY,
        "bgra8": cv2.COLOR_BGRA2GRAY,
    }[encoding]
    return cv2.cvtColor(np.ascontiguousarray(pixels), code)


def decode_image(msg: Any) -> np.ndarray:
    """BGR (H, W, 3) uint8 pixels of an Image or a CompressedImage (JPEG, PNG...).

    Raises UnsupportedEncodingError for an encoding or a compressed payload it cannot read.
    """
    if hasattr(msg, "encoding"):
        return image_to_bgr(msg)
    import cv2

    pixels = cv2.imdecode(np.asarray(msg.data, dtype=np.uint8).reshape(-1), cv2.IMREAD_COLOR)
    if pixels is None:
        raise UnsupportedEncodingError(
            f"undecodable CompressedImage (format '{msg.format}', {len(msg.data)} bytes)",
            "undecodable compressed image",
        )
    return pixels


def array_to_image(pixels: np.ndarray, encoding: str, stamp: Time, frame_id: str) -> Image:
    """An Image message holding `pixels` ((H, W) for mono8, (H, W, 3) for bgr8/rgb8, uint8)."""
    channels = SUPPORTED_ENCODINGS.get(encoding)
    if channels is None:
        raise UnsupportedEncodingError(
            f"cannot publish encoding '{encoding}'", f"unsupported encoding '{encoding}'"
        )
    expected_shape = "(H, W)" if channels == 1 else f"(H, W, {channels})"
    if pixels.dtype != np.uint8 or pixels.shape[2:] != (() if channels == 1 else (channels,)):
        raise ValueError(
            f"{encoding} needs a uint8 array {expected_shape}, got {pixels.dtype} {pixels.shape}"
        )
    from sensor_msgs.msg import Image

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
    from tracker_msgs.msg import Rect as RectMsg

    return RectMsg(
        x=float(rect.x), y=float(rect.y), width=float(rect.width), height=float(rect.height)
    )


def msg_to_rect(msg: RectMsg) -> Rect:
    values = (msg.x, msg.y, msg.width, msg.height)
    if not all(math.isfinite(v) for v in values) or msg.width < 0 or msg.height < 0:
        raise ValueError(f"invalid rectangle {values}")
    return Rect(*values)


def msg_to_window(msg: RectMsg) -> Rect:
    """A camera window (PtzState.window): a rectangle of positive size whose values are usable
    (`usable_value`), else ValueError."""
    window = msg_to_rect(msg)
    values = (window.x, window.y, window.width, window.height)
    if not all(map(usable_value, values)):
        raise ValueError(f"window {values} is beyond +-{MAX_MESSAGE_VALUE:g}")
    if window.width <= 0 or window.height <= 0:
        raise ValueError(f"empty rectangle {values}")
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
    from sensor_msgs.msg import CameraInfo

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


@cache
def typestore() -> Typestore:
    """rosbags' type store for reading and writing bags: ROS 2 Jazzy's standard types plus
    tracker_msgs (from the installed .msg files)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from tracker_msgs_py.package_files import package_data

    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for path in sorted(package_data("tracker_msgs", "msg").glob("*.msg")):
        types.update(get_types_from_msg(path.read_text(), f"tracker_msgs/msg/{path.stem}"))
    store.register(types)
    return store
