"""rosbag2 recording and reading of the suite's topics with `rosbags` (no rclpy).

The bags are ordinary rosbag2 (MCAP by default) with the message definitions embedded, so
`ros2 bag play`, Foxglove and our video_source read them.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Reader, StoragePlugin, Writer

from tracker_msgs_py.codec import IMAGE_TYPES, typestore


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
    """(topic, receive time ns, deserialized message) for every message, in time order."""
    store = typestore()
    with Reader(path) as reader:
        connections = [c for c in reader.connections if topics is None or c.topic in topics]
        for connection, timestamp, data in reader.messages(connections=connections):
            yield connection.topic, timestamp, store.deserialize_cdr(data, connection.msgtype)


def topic_counts(path: Path) -> dict[str, int]:
    with Reader(path) as reader:
        return {c.topic: c.msgcount for c in reader.connections}
