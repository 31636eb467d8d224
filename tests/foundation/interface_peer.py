"""One side of the cross-process interface test (run as a separate process with the install space).

    interface_peer.py serve   -- echoes every tracker_msgs message from rt/in/<Name> to rt/out/<Name>
                                 and answers every tracker_msgs service with a response derived from
                                 the request
    interface_peer.py probe   -- publishes a fully populated message of every type, checks the echo
                                 field by field, calls every service and checks the responses; prints
                                 one JSON report and exits 0 when everything round-tripped

Every field of every interface gets a distinctive non-default value by introspection, so a field
added later is covered without touching this file.
"""

from __future__ import annotations

import array
import importlib
import inspect
import json
import sys
import time
import zlib

import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractString,
    Array,
    BasicType,
    NamespacedType,
)

import tracker_msgs.msg
import tracker_msgs.srv
from tracker_msgs_py import stop_signals

QOS = QoSProfile(
    depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
TIMEOUT_S = 30.0


def message_classes() -> dict[str, type]:
    return dict(inspect.getmembers(tracker_msgs.msg, inspect.isclass))


def service_classes() -> dict[str, type]:
    return {
        name: cls
        for name, cls in inspect.getmembers(tracker_msgs.srv, inspect.isclass)
        if hasattr(cls, "Request") and hasattr(cls, "Response")
    }


def _class_of(slot: NamespacedType) -> type:
    module = importlib.import_module(".".join(slot.namespaces))
    return getattr(module, slot.name)


def _basic_value(typename: str, seed: int) -> object:
    if typename == "boolean":
        return seed % 2 == 1
    if typename in ("octet", "uint8", "char"):
        return 200 + seed % 50
    if typename.startswith("uint"):
        bits = int(typename[4:])
        return 2**bits - 1 - seed  # near the top of the range: catches sign/width bugs
    if typename.startswith("int"):
        bits = int(typename[3:])
        return -(2 ** (bits - 1)) + seed
    if typename == "float":
        return -1.5 - seed * 0.25  # exactly representable in float32
    if typename in ("double", "long double"):
        return -123.456789e-3 * (seed + 1) + 1e9  # needs all 64 bits
    raise TypeError(f"no value rule for {typename}")


def _value(slot: object, seed: int) -> object:
    if isinstance(slot, BasicType):
        return _basic_value(slot.typename, seed)
    if isinstance(slot, AbstractString):
        return f"ñ-{seed}-ü"  # non-ASCII: checks UTF-8 on the wire
    if isinstance(slot, NamespacedType):
        return populated(_class_of(slot), seed)
    if isinstance(slot, AbstractNestedType):
        size = slot.size if isinstance(slot, Array) else 3
        return [_value(slot.value_type, seed * 7 + i + 1) for i in range(size)]
    raise TypeError(f"no value rule for {slot}")


def populated(cls: type, seed: int) -> object:
    """An instance of message class `cls` with every field set to a distinctive value."""
    msg = cls()
    fields = cls.get_fields_and_field_types()
    for index, (field, slot) in enumerate(zip(fields, cls.SLOT_TYPES, strict=True)):
        setattr(msg, field, _value(slot, seed * 31 + index + 1))
    return msg


def as_plain(value: object) -> object:
    """Messages, arrays and sequences as JSON-comparable dicts and lists."""
    if hasattr(value, "get_fields_and_field_types"):
        return {name: as_plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if isinstance(value, np.ndarray | array.array | list | tuple):
        return [as_plain(v) for v in value]
    if isinstance(value, bytes):
        return list(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def response_for(srv: type, request: object) -> object:
    """The response the server gives: populated from a seed derived from the request's content."""
    seed = zlib.crc32(json.dumps(as_plain(request), sort_keys=True).encode()) % 1000
    return populated(srv.Response, seed)


def serve() -> None:
    node = Node("interface_echo")
    publishers = {}
    for name, cls in message_classes().items():
        publishers[name] = node.create_publisher(cls, f"rt/out/{name}", QOS)
        node.create_subscription(cls, f"rt/in/{name}", publishers[name].publish, QOS)
    for name, srv in service_classes().items():

        def answer(request: object, response: object, srv: type = srv) -> object:
            return response_for(srv, request)

        node.create_service(srv, f"rt/{name}", answer)
    # Stopped as the suite's nodes are (tracker_msgs_py.node_main): the stop only sets a flag,
    # and the loop leaves between two waits.
    while not stop_signals.requested():
        rclpy.spin_once(node, timeout_sec=0.1)


def probe() -> int:
    node = Node("interface_probe")
    report: dict[str, str] = {}
    received: dict[str, object] = {}
    sent: dict[str, object] = {}
    keep = []
    for seed, (name, cls) in enumerate(message_classes().items()):
        sent[name] = populated(cls, seed + 1)
        keep.append(
            node.create_subscription(
                cls, f"rt/out/{name}", lambda msg, name=name: received.setdefault(name, msg), QOS
            )
        )
        node.create_publisher(cls, f"rt/in/{name}", QOS).publish(sent[name])
    deadline = time.monotonic() + TIMEOUT_S
    while len(received) < len(sent) and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    for name, msg in sent.items():
        if name not in received:
            report[name] = "no echo received"
        elif as_plain(received[name]) != as_plain(msg):
            report[name] = f"mismatch: sent {as_plain(msg)} got {as_plain(received[name])}"
        else:
            report[name] = "ok"
    for seed, (name, srv) in enumerate(service_classes().items()):
        client = node.create_client(srv, f"rt/{name}")
        if not client.wait_for_service(timeout_sec=TIMEOUT_S):
            report[name] = "service not available"
            continue
        request = populated(srv.Request, seed + 11)
        future = client.call_async(request)
        rclpy.spin_until_future_complete(node, future, timeout_sec=TIMEOUT_S)
        if not future.done():
            report[name] = "no response"
        elif as_plain(future.result()) != as_plain(response_for(srv, request)):
            report[name] = f"mismatch: got {as_plain(future.result())}"
        else:
            report[name] = "ok"
    print(json.dumps(report, sort_keys=True), flush=True)
    return 0 if all(v == "ok" for v in report.values()) else 1


def main() -> int:
    stop_signals.install()  # also: every thread's stack on SIGUSR1, should it ever hang
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    try:
        if sys.argv[1] == "serve":
            serve()
            return 0
        return probe()
    except KeyboardInterrupt:
        return 0
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
