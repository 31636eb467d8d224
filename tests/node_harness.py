"""A node under test and a peer node on a private rclpy context, spun by hand (in-process tests)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter


class NodeHarness:
    """`make_node(context=..., parameter_overrides=...)` plus a peer that publishes `inputs` and
    records `outputs` ({topic: (type, qos)}); received messages are in `received[topic]`."""

    def __init__(
        self,
        make_node: Callable[..., Any],
        inputs: dict[str, tuple[type, Any]],
        outputs: dict[str, tuple[type, Any]],
        **params: Any,
    ) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        overrides = [Parameter(name, value=value) for name, value in params.items()]
        self.node = make_node(context=self.context, parameter_overrides=overrides)
        self.peer = rclpy.create_node("harness_peer", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.executor.add_node(self.peer)
        self.publishers = {
            topic: self.peer.create_publisher(kind, topic, qos)
            for topic, (kind, qos) in inputs.items()
        }
        self.received: dict[str, list] = {topic: [] for topic in outputs}
        for topic, (kind, qos) in outputs.items():
            self.peer.create_subscription(kind, topic, self.received[topic].append, qos)
        self.spin_until(self._connected, timeout=10.0)

    def _connected(self) -> bool:
        subscribed = all(p.get_subscription_count() > 0 for p in self.publishers.values())
        heard = all(self.peer.count_publishers(topic) > 0 for topic in self.received)
        return subscribed and heard

    def publish(self, topic: str, msg: Any) -> None:
        self.publishers[topic].publish(msg)

    def feed(self, topic: str, msg: Any, timeout: float = 5.0) -> None:
        """Publish `msg` and spin until the node has handled it (a SuiteNode counts them)."""
        handled = self.node.messages_handled(topic)
        self.publish(topic, msg)
        self.spin_until(lambda: self.node.messages_handled(topic) > handled, timeout)

    def spin_until(self, condition: Callable[[], bool], timeout: float = 5.0) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, "timed out waiting for the node"
            self.executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.peer.destroy_node()
        rclpy.shutdown(context=self.context)
