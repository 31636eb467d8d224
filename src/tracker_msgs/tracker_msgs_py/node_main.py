"""How the suite's nodes start, run, report bad input and stop.

`SuiteNode` is the base of every node: it owns the node's worker threads and its `ProblemLog`.
`run_node` spins one node until a stop signal or until the node finishes, then tears it down in
the one safe order:

    stop requested (SIGINT/SIGTERM, or the node finished)
      -> `stopping` is set and the node's wakers run: workers leave their waits
      -> the workers are joined: from here on no thread of the node publishes
      -> the node's entities are destroyed -> the ROS context is shut down

A shutdown is never a failure: the exit code is 0 unless the node itself reported one (2 when it
cannot start, e.g. a bad path or parameter, printed once without a traceback).

The teardown has a deadline (`TEARDOWN_S`): the middleware's own teardown has been seen to block
(rclpy's `Node.destroy_node` waiting in the middleware while the rest of the graph was stopping
too, holding the interpreter lock: a replay then lost the node to SIGKILL). Past the deadline the
process writes its threads' stacks to stderr and exits with its code without waiting longer
(`exit_deadline`: a C-level timer, so it fires even while the interpreter is blocked); by then
its workers are joined and nothing of the node publishes.

The process spins its nodes with rclpy's EventsExecutor unless `--executor single` comes among
its arguments (before `--ros-args`): the default SingleThreadedExecutor rebuilds its wait set on
every wake-up, which cost a camera or replay node about as much CPU per frame as its own work
(bench/bench_replay.py measures both). rclpy's MultiThreadedExecutor is not offered: each node's
callbacks run one at a time anyway (one callback group per node, its state not shared between
threads), so it only adds a thread pool contending for the interpreter lock: the motion graph in
one process on 40 frames of vtest.avi ran at 13.3 frames/s under it against 32.6 under the
events executor, with the same tracks (2026-12-02).
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSPolicyKind, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.subscription import Subscription
from rclpy.timer import Timer

from tracker_msgs_py import stop_signals
from tracker_msgs_py.codec import stamp_to_ns
from tracker_msgs_py.exit_deadline import ExitDeadline
from tracker_msgs_py.node_stats import RECEIVED_SUFFIX, InputStats
from tracker_msgs_py.params import ParameterError, parameters_for_every_node
from tracker_msgs_py.problems import ProblemLog

OUTPUT_SUFFIX = ": output"  # the diagnostic status of a node's published topics
READERS_SUFFIX = " readers"  # its values: "<topic> readers" = readers matched by the publisher
INPUT_SUFFIX = ": input"  # the diagnostic status of a node's subscribed topics
WRITERS_SUFFIX = " writers"  # among its values: "<topic> writers" = writers its reader matched
BUSY_KEY = "busy in callbacks [s]"  # among them too: wall time handling messages since the start
SIGNAL_POLL_S = 0.1  # longest a stop signal waits for the executor to return to Python
WORKER_JOIN_S = 1.5  # workers get this long to leave (the node must exit within 2 s)
TEARDOWN_S = 1.8  # the whole teardown, workers included, before the process exits regardless
LAST_REPORT_ACK_S = 0.5  # of it, the longest the nodes' last reports wait to be acknowledged
DIAGNOSTICS_PERIOD_S = 1.0
INPUT_SILENCE_S = 3.0  # an input that came and has been silent this long: WARN


class Health(Enum):
    """A diagnostic status level (diagnostic_msgs/DiagnosticStatus), as its byte."""

    OK = DiagnosticStatus.OK
    WARN = DiagnosticStatus.WARN
    ERROR = DiagnosticStatus.ERROR


QOS_OVERRIDES_PREFIX = "qos_overrides."  # rclpy declares these only for the topics that use them


class StartupError(RuntimeError):
    """A node cannot start (bad input path, bad parameters...): the message is shown to the user."""


class SuiteNode(Node):
    """A node that stops its threads before its entities go away and reports bad input once.

    Workers (`start_worker`) run beside the executor. A worker must wait only with
    `self.stopping.wait(...)` or on something a waker (`add_waker`) releases, must check
    `self.stopping` before it publishes, and must return soon after `stopping` is set.
    `finish(code)` ends the node from inside (a replay that reached its end).
    `problems.report(cause, detail)` logs the first of each cause of dropped input and counts the
    rest. Once a second, and once more as its process ends, the node publishes on `/diagnostics`
    (diagnostic_msgs/DiagnosticArray) a status "<node>: state" (`diagnostic_state()`, which
    nodes override: what it is doing) and a status "<node>: input": the dropped input by cause,
    and per subscribed topic the message rate, the time its callback took (mean/max) and the
    data's age on arrival (the node's clock minus the header stamp: on a live camera how old the
    image is; in a replay, on the replay's clock);
    and the writers its subscription has matched (`WRITERS_SUFFIX`); and a status
    "<node>: output": per published topic, the readers its publisher has matched
    (`READERS_SUFFIX`). A runner waits on both before frame 0 (`matched_readers`,
    `matched_writers`): a message sent before both ends have matched each other is lost.
    """

    def __init__(self, node_name: str, **node_options: Any) -> None:
        # Before Node's own __init__: with use_sim_time it already subscribes to /clock.
        self._inputs: dict[str, InputStats] = {}
        self._outputs: dict[str, Publisher] = {}
        self._readers: dict[str, list[Subscription]] = {}  # per resolved topic
        self._ros_args = list(node_options.get("cli_args") or []) + (
            sys.argv if node_options.get("use_global_arguments", True) else []
        )
        super().__init__(node_name, **node_options)
        self.stopping = threading.Event()
        self.finished = threading.Event()
        self.exit_code = 0
        self.problems = ProblemLog(self.get_logger().warning)
        self._workers: list[threading.Thread] = []
        self._wakers: list[Callable[[], None]] = []
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._diagnostics_seen = 0
        self._diagnostics_at = time.monotonic()
        self.create_steady_timer(DIAGNOSTICS_PERIOD_S, self._publish_diagnostics)

    def create_steady_timer(self, period_s: float, callback: Callable[[], None]) -> Timer:
        """A timer on wall time (the steady clock), for waits and reports: with use_sim_time
        the node's own clock stands still while a lockstep replay waits."""
        return self.create_timer(period_s, callback, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def unused_overrides(self) -> list[str]:
        """Parameters given to this node by name (its params-file section, `-p node:name:=`,
        run_demo's `--set`) that it did not declare: ROS ignores them without a word, so a
        misspelt name changes nothing. Those given to every node (`/**`) are left out. rclpy
        keeps the given values in `_parameter_overrides` and has no public accessor for them."""
        given = getattr(self, "_parameter_overrides", {})
        for_every_node = parameters_for_every_node(self._ros_args)
        return sorted(
            name
            for name in given
            if not self.has_parameter(name)
            and name not in for_every_node
            and not name.startswith(QOS_OVERRIDES_PREFIX)
        )

    def warn_unused_overrides(self) -> None:
        """One warning naming the parameters given but not declared (see `unused_overrides`)."""
        unused = self.unused_overrides()
        if unused:
            self.get_logger().warning(
                f"ignored parameter(s) {', '.join(unused)}: this node does not declare them "
                "(misspelt, or meant for a method other than the one chosen)"
            )

    # --- threads and ending -----------------------------------------------------------------

    def start_worker(self, target: Callable[[], None], name: str) -> threading.Thread:
        """Run `target` in a thread of the node. If it raises (outside a shutdown), the error is
        logged with its traceback and the node finishes with exit code 1: never a silent hang."""

        def run() -> None:
            try:
                target()
            except Exception:
                if not self.stopping.is_set():
                    self.get_logger().error(f"{name} failed:\n{traceback.format_exc()}")
                    self.finish(1)

        thread = threading.Thread(target=run, name=f"{self.get_name()}.{name}", daemon=True)
        self._workers.append(thread)
        thread.start()
        return thread

    def add_waker(self, wake: Callable[[], None]) -> None:
        """`wake()` is called once stopping begins, to release a worker's wait."""
        self._wakers.append(wake)

    def finish(self, exit_code: int = 0) -> None:
        """The node's work is done (callable from a worker): the runner stops the node."""
        self.exit_code = exit_code
        self.finished.set()
        executor = self.executor
        if executor is not None:
            executor.wake()

    def stop_workers(self, timeout: float = WORKER_JOIN_S) -> list[str]:
        """Set `stopping`, wake and join the workers; the names of any still running."""
        self.stopping.set()
        for wake in self._wakers:
            wake()
        deadline = time.monotonic() + timeout
        current = threading.current_thread()
        for thread in self._workers:
            if thread is not current:
                thread.join(max(0.0, deadline - time.monotonic()))
        stuck = [t.name for t in self._workers if t.is_alive() and t is not current]
        if stuck:
            self.get_logger().error(f"threads still running after {timeout} s: {stuck}")
        return stuck

    def destroy_node(self) -> None:
        self.stop_workers()
        if self.problems.total:
            self.get_logger().info(f"dropped input: {self.problems.summary()}")
        super().destroy_node()

    # --- QoS ------------------------------------------------------------------------------------

    def create_subscription(
        self,
        msg_type: Any,
        topic: str,
        callback: Callable[[Any], None],
        qos_profile: QoSProfile | int,
        **kwargs: Any,
    ) -> Subscription:
        """rclpy's, plus a warning naming the cause when a publisher's QoS cannot match, and for
        images the QoS overridable by parameter (`_overridable`)."""
        _overridable(msg_type, kwargs)
        if kwargs.get("event_callbacks") is None:
            kwargs["event_callbacks"] = SubscriptionEventCallbacks(
                incompatible_qos=lambda event: self._incompatible_qos(topic, qos_profile, event)
            )
        stats = self._inputs.setdefault(topic, InputStats())

        def measured(msg: Any) -> None:
            started = time.perf_counter()
            try:
                callback(msg)
            finally:
                stats.record(time.perf_counter() - started, self._age_s(msg))

        subscription = super().create_subscription(msg_type, topic, measured, qos_profile, **kwargs)
        self._readers.setdefault(subscription.topic_name, []).append(subscription)
        return subscription

    def messages_handled(self, topic: str) -> int:
        """Messages of `topic` (as subscribed) whose callback has run since the node started."""
        stats = self._inputs.get(topic)
        return stats.total if stats is not None else 0

    def destroy_subscription(self, subscription: Subscription) -> bool:
        readers = self._readers.get(subscription.topic_name, [])
        if subscription in readers:
            readers.remove(subscription)
        return super().destroy_subscription(subscription)

    def _age_s(self, msg: Any) -> float | None:
        header = getattr(msg, "header", None)
        if header is None:
            return None
        return (self.get_clock().now().nanoseconds - stamp_to_ns(header.stamp)) / 1e9

    def create_publisher(
        self, msg_type: Any, topic: str, qos_profile: QoSProfile | int, **kwargs: Any
    ) -> Publisher:
        """rclpy's, plus a warning naming the cause when a subscriber's QoS cannot match, and for
        images the QoS overridable by parameter (`_overridable`)."""
        _overridable(msg_type, kwargs)
        if kwargs.get("event_callbacks") is None:
            kwargs["event_callbacks"] = PublisherEventCallbacks(
                incompatible_qos=lambda event: self._incompatible_qos(topic, qos_profile, event)
            )
        publisher = super().create_publisher(msg_type, topic, qos_profile, **kwargs)
        self._outputs[publisher.topic_name] = publisher
        return publisher

    def destroy_publisher(self, publisher: Publisher) -> bool:
        if self._outputs.get(publisher.topic_name) is publisher:
            del self._outputs[publisher.topic_name]
        return super().destroy_publisher(publisher)

    def _incompatible_qos(self, topic: str, qos: QoSProfile | int, event: Any) -> None:
        policy = QoSPolicyKind(event.last_policy_kind)
        cause = f"incompatible QoS on {topic}"
        detail = (
            f"{self.resolve_topic_name(topic)}: a peer's QoS cannot match this node's "
            f"({policy.name.lower()}): no messages pass between them"
        )
        if policy is QoSPolicyKind.RELIABILITY:
            reliable = getattr(qos, "reliability", None) == ReliabilityPolicy.RELIABLE
            detail += (
                ". This node asks for reliable delivery and the publisher is best effort (camera "
                "drivers publish images with sensor-data QoS): set reliable_images:=false"
                if reliable
                else ". A best-effort publisher here cannot serve a reliable subscriber"
            )
        self.problems.report(cause, detail)

    # --- diagnostics ----------------------------------------------------------------------------

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        """What the node is doing (e.g. "tracking track 3", "search"), and figures about it."""
        return "running", {}

    def diagnostic_health(self) -> tuple[Health, str]:
        """How well the node can do its work: OK, WARN (degraded: waiting for an input, holding
        the camera) or ERROR (it cannot work: a required input never came), and why."""
        return Health.OK, ""

    @property
    def hardware_id(self) -> str:
        """The unit the node serves, as diagnostic_updater names it: `ptz`, or `ptz` + the
        namespace of a unit among several (`ptz/cam1`)."""
        namespace = self.get_namespace().strip("/")
        return f"ptz/{namespace}" if namespace else "ptz"

    def publish_last_report(self) -> None:
        """The node's diagnostics once more as its process ends (what it did up to its end: a
        graph in one process ends with its replay, before the next report was due)."""
        self._publish_diagnostics()

    def wait_for_last_report(self, timeout_s: float) -> bool:
        """Until the subscribers have acknowledged the diagnostics published (at most
        `timeout_s`): a writer destroyed right after publishing drops what is not yet delivered,
        and on a busy machine the last report was lost that way."""
        return self._diagnostics_pub.wait_for_all_acked(Duration(seconds=max(0.0, timeout_s)))

    def _publish_diagnostics(self) -> None:
        revision = self.problems.revision
        recent = revision != self._diagnostics_seen
        self._diagnostics_seen = revision
        now = time.monotonic()
        period, self._diagnostics_at = now - self._diagnostics_at, now
        figures = [(c, str(n)) for c, n in sorted(self.problems.counts.items())]
        for topic, stats in self._inputs.items():
            figures += stats.report(self.resolve_topic_name(topic), period)
        figures.append((BUSY_KEY, f"{sum(s.busy_s for s in self._inputs.values()):.6f}"))
        figures += [
            (f"{topic}{WRITERS_SUFFIX}", str(min(r.get_publisher_count() for r in readers)))
            for topic, readers in sorted(self._readers.items())
            if readers
        ]
        name = self.get_fully_qualified_name()
        state, details = self.diagnostic_state()
        health, why = self.diagnostic_health()
        silent = [
            f"no message on {self.resolve_topic_name(topic)} for {now - stats.last_at:.0f} s"
            for topic, stats in sorted(self._inputs.items())
            if stats.last_at is not None and now - stats.last_at > INPUT_SILENCE_S
        ]
        input_message = "; ".join([self.problems.summary(), *silent]).strip("; ")
        array = DiagnosticArray(
            status=[
                DiagnosticStatus(
                    level=health.value,
                    name=f"{name}: state",
                    message=f"{state}: {why}" if why else state,
                    hardware_id=self.hardware_id,
                    values=[KeyValue(key=k, value=v) for k, v in details.items()],
                ),
                DiagnosticStatus(
                    level=(Health.WARN if recent or silent else Health.OK).value,
                    name=f"{name}{INPUT_SUFFIX}",
                    message=input_message or "no input dropped",
                    hardware_id=self.hardware_id,
                    values=[KeyValue(key=k, value=v) for k, v in figures],
                ),
                DiagnosticStatus(
                    level=DiagnosticStatus.OK,
                    name=f"{name}{OUTPUT_SUFFIX}",
                    hardware_id=self.hardware_id,
                    message=f"{len(self._outputs)} published topics",
                    values=[
                        KeyValue(
                            key=f"{topic}{READERS_SUFFIX}",
                            value=str(publisher.get_subscription_count()),
                        )
                        for topic, publisher in sorted(self._outputs.items())
                    ],
                ),
            ]
        )
        array.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics_pub.publish(array)


#: Streams whose QoS a user may need to fit to a camera driver or a recorder: images and their
#: camera infos (the other topics' QoS is fixed by meaning: results, commands).
OVERRIDABLE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage",
                     "sensor_msgs/msg/CameraInfo")  # fmt: skip


def _overridable(msg_type: Any, kwargs: dict[str, Any]) -> None:
    """Image streams' QoS from `qos_overrides.<topic>.<publisher|subscription>.<policy>`
    parameters (reliability, history, depth, durability), as rclcpp's and rclpy's
    QoSOverridingOptions declare them: e.g. `-p qos_overrides./camera/image_raw.subscription.
    reliability:=best_effort`. The node's own choice (reliable_images) is the default."""
    from rclpy.qos_overriding_options import QoSOverridingOptions

    name = f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"
    if name in OVERRIDABLE_TYPES and kwargs.get("qos_overriding_options") is None:
        kwargs["qos_overriding_options"] = QoSOverridingOptions.with_default_policies()


def _events_executor() -> Executor:
    from rclpy.experimental import EventsExecutor

    return EventsExecutor()


#: rclpy's executors by name: the default one thread, a thread pool, the experimental events one.
EXECUTORS: dict[str, Callable[[], Executor]] = {
    "single": SingleThreadedExecutor,
    "events": _events_executor,
}
DEFAULT_EXECUTOR = "events"


def executor_argument(args: Sequence[str] | None = None) -> str:
    """The executor a node process asks for with `--executor NAME` among its non-ROS arguments
    (`args`, else the command line); `DEFAULT_EXECUTOR` without one."""
    from rclpy.utilities import remove_ros_args

    plain = remove_ros_args(list(sys.argv if args is None else args))
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--executor", choices=list(EXECUTORS), default=DEFAULT_EXECUTOR)
    known, _ = parser.parse_known_args(plain)
    return str(known.executor)


class NodeGroup:
    """The nodes of one process, spun by one executor (`run_nodes`)."""

    def __init__(self, executor: str = DEFAULT_EXECUTOR) -> None:
        self.executor = EXECUTORS[executor]()
        self.nodes: list[SuiteNode] = []

    def add(self, node: SuiteNode) -> SuiteNode:
        node.warn_unused_overrides()  # its parameters are declared once it is constructed
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin_once(self) -> None:
        self.executor.spin_once(timeout_sec=SIGNAL_POLL_S)

    @property
    def finished(self) -> bool:
        return any(node.finished.is_set() for node in self.nodes)

    @property
    def exit_code(self) -> int:
        return next((node.exit_code for node in self.nodes if node.exit_code), 0)


def run_nodes(
    start: Callable[[NodeGroup], object],
    args: Sequence[str] | None = None,
    executor: str | None = None,
) -> int:
    """`start(group)` creates the process's nodes (adding them to the group, and spinning it if
    it must wait for something); then spin them until a stop signal or until one finishes, tear
    them all down in order, and return the process exit code (see the module docstring).
    `executor` names the rclpy executor (`EXECUTORS`; None: the `--executor` argument)."""
    executor = executor or executor_argument(args)
    stop_signals.install()
    rclpy.init(
        args=None if args is None else list(args),
        signal_handler_options=SignalHandlerOptions.NO,
    )
    group = NodeGroup(executor)
    code = 0
    try:
        if stop_signals.requested():
            return 0
        start(group)
        while not stop_signals.requested() and not group.finished:
            group.spin_once()
        code = group.exit_code
    except (StartupError, ParameterError) as error:
        print(f"[FATAL] {error}", file=sys.stderr, flush=True)
        code = 2
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        deadline = ExitDeadline(TEARDOWN_S, code)
        group.executor.shutdown(timeout_sec=0.0)
        for node in reversed(group.nodes):
            node.publish_last_report()
        acknowledged_by = time.monotonic() + LAST_REPORT_ACK_S
        for node in reversed(group.nodes):
            node.wait_for_last_report(acknowledged_by - time.monotonic())
        for node in reversed(group.nodes):
            node.destroy_node()
        rclpy.try_shutdown()
        deadline.cancel()
    return code


def run_node(make_node: Callable[[], SuiteNode], args: Sequence[str] | None = None) -> int:
    """Create the node, spin it until a stop signal or until it finishes, tear it down in order,
    and return the process exit code (see the module docstring)."""
    return run_nodes(lambda group: group.add(make_node()), args)


def matched_writers(array: DiagnosticArray) -> dict[str, dict[str, int]]:
    """Per node and subscribed topic, the writers its subscription had matched (the fewest of
    its subscriptions to that topic), from nodes' diagnostics (the "<node>: input" status)."""
    nodes: dict[str, dict[str, int]] = {}
    for status in array.status:
        if status.name.endswith(INPUT_SUFFIX):
            nodes[status.name[: -len(INPUT_SUFFIX)]] = {
                value.key[: -len(WRITERS_SUFFIX)]: int(value.value)
                for value in status.values
                if value.key.endswith(WRITERS_SUFFIX) and value.value.isdigit()
            }
    return nodes


@dataclass(frozen=True)
class CallbackLoad:
    """A node's wall time in its callbacks since it started and the messages it had received
    per topic, from one of its diagnostics reports (the two agree: the same moment)."""

    busy_s: float
    received: dict[str, int]

    def per_message(self, topic: str) -> float | None:
        """Busy seconds per message of `topic` (None before the first)."""
        count = self.received.get(topic, 0)
        return self.busy_s / count if count else None


def callback_load(array: DiagnosticArray) -> dict[str, CallbackLoad]:
    """Per node, its `CallbackLoad` from nodes' diagnostics (the "<node>: input" status)."""
    loads: dict[str, CallbackLoad] = {}
    for status in array.status:
        if not status.name.endswith(INPUT_SUFFIX):
            continue
        values = {value.key: value.value for value in status.values}
        try:
            busy = float(values[BUSY_KEY])
        except (KeyError, ValueError):
            continue
        received = {
            key[: -len(RECEIVED_SUFFIX)]: int(value)
            for key, value in values.items()
            if key.endswith(RECEIVED_SUFFIX) and value.isdigit()
        }
        loads[status.name[: -len(INPUT_SUFFIX)]] = CallbackLoad(busy, received)
    return loads


def matched_readers(array: DiagnosticArray) -> dict[str, int]:
    """Per published topic, the readers its publisher had matched, from a node's diagnostics
    (the "<node>: output" status; empty for other arrays). The graph's view from any one node
    can list a reader that the publisher itself has not matched yet: this is the publisher's."""
    counts: dict[str, int] = {}
    for status in array.status:
        if status.name.endswith(OUTPUT_SUFFIX):
            for value in status.values:
                if value.key.endswith(READERS_SUFFIX) and value.value.isdigit():
                    counts[value.key[: -len(READERS_SUFFIX)]] = int(value.value)
    return counts
