"""rosbag2 recording and reading of the suite's topics with `rosbags` (no rclpy).

The bags are ordinary rosbag2 (MCAP by default) with the message definitions embedded, so
`ros2 bag play`, Foxglove and our video_source read them. Images are recorded as JPEG
(sensor_msgs/CompressedImage on `<topic>/compressed`, image_transport's name) unless raw images
are asked for: a demo run of vtest.avi is then ~50 MB instead of 1.2 GB. Readers here ask for the
raw name and get the compressed stream when that is what the bag holds.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from rosbags.rosbag2 import Reader, StoragePlugin, Writer

from tracker_msgs_py.codec import IMAGE_TYPES, decode_image, typestore

RAW_IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
COMPRESSED = "/compressed"
JPEG_QUALITY = 65  # vtest.avi's 795 frames: ~50 MB of scene and camera images


def recorded_topics(topics: dict[str, str], raw_images: bool = False) -> dict[str, str]:
    """The bag's topics and types for the graph's `topics`: each Image topic as its
    `/compressed` CompressedImage unless `raw_images`."""
    if raw_images:
        return dict(topics)
    return {
        (f"{name}{COMPRESSED}" if kind == RAW_IMAGE else name): (
            COMPRESSED_IMAGE if kind == RAW_IMAGE else kind
        )
        for name, kind in topics.items()
    }


def jpeg_cdr(image_cdr: bytes, quality: int = JPEG_QUALITY) -> bytes:
    """A serialized sensor_msgs/Image as a serialized JPEG sensor_msgs/CompressedImage (same
    header)."""
    store = typestore()
    image: Any = store.deserialize_cdr(image_cdr, RAW_IMAGE)
    ok, encoded = cv2.imencode(".jpg", decode_image(image), [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError(f"could not encode a {image.width}x{image.height} image as JPEG")
    compressed = store.types[COMPRESSED_IMAGE](
        header=image.header, format="jpeg", data=np.asarray(encoded, dtype=np.uint8).reshape(-1)
    )
    return bytes(store.serialize_cdr(compressed, COMPRESSED_IMAGE))


def exact_cdr(data: bytes, msgtype: str) -> bytes:
    """`data` cut to the length of the message it encodes.

    Fast CDR (rclpy, Fast DDS) over-allocates some messages with empty strings and ships the
    unused tail; rosbags, like other strict readers, rejects such a message. Images never need
    this, and are skipped because decoding them costs time.
    """
    store = typestore()
    msgdef = store.get_msgdef(msgtype)
    little_endian = len(data) > 1 and bool(data[1])
    decode = msgdef.deserialize_cdr_le if little_endian else msgdef.deserialize_cdr_be
    _, end = decode(memoryview(data)[4:], 0, msgdef.cls, store)
    return bytes(data[: 4 + end])


class BagWriter:
    """Writes serialized (CDR) messages of known topics into a new rosbag2 directory."""

    def __init__(self, path: Path, topics: dict[str, str], storage: str = "mcap") -> None:
        if path.exists():
            raise FileExistsError(f"{path} exists: remove it or choose another output")
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.path = path
        self._writer = Writer(path, version=9, storage_plugin=plugin)
        self._writer.open()
        store = typestore()
        self._connections = {
            topic: self._writer.add_connection(topic, msgtype, typestore=store)
            for topic, msgtype in topics.items()
        }
        self.counts = dict.fromkeys(topics, 0)

    def write(self, topic: str, stamp_ns: int, data: bytes) -> None:
        connection = self._connections[topic]
        if connection.msgtype not in IMAGE_TYPES:
            data = exact_cdr(data, connection.msgtype)
        self._writer.write(connection, stamp_ns, data)
        self.counts[topic] += 1

    def close(self) -> None:
        self._writer.close()


def read_bag(path: Path, topics: set[str] | None = None) -> Iterator[tuple[str, int, Any]]:
    """(topic, receive time ns, deserialized message) for every message, in time order. An image
    topic asked for by its raw name comes from `<topic>/compressed` when the bag holds that
    instead (and is reported under the raw name)."""
    store = typestore()
    with Reader(path) as reader:
        held = {c.topic for c in reader.connections}
        names = {}
        for topic in held:
            raw = topic.removesuffix(COMPRESSED)
            wanted = topics is None or topic in topics
            alias = topic != raw and raw not in held and topics is not None and raw in topics
            if wanted or alias:
                names[topic] = raw if alias else topic
        connections = [c for c in reader.connections if c.topic in names]
        if not connections:  # rosbags reads every connection when given none
            return
        for connection, timestamp, data in reader.messages(connections=connections):
            message = store.deserialize_cdr(data, connection.msgtype)
            yield names[connection.topic], timestamp, message


def topic_counts(path: Path) -> dict[str, int]:
    with Reader(path) as reader:
        return {c.topic: c.msgcount for c in reader.connections}
