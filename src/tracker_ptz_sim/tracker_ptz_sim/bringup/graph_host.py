"""graph_host: every node of a graph in one process on one executor (`run_demo --single-process`).

    graph_host --graph surveillance [--set node.param=value ...]

The same node classes with the same parameters (the graph's files, then the overrides) and
remappings as the separate processes get (`graph.ros_args`, passed as each node's own arguments),
so a replay gives the same tracks. The processing nodes start first; once every topic of the graph
has the subscribers `graph.ready` names (the recorder's included, in another process) and a moment
more for them to match, video_source starts. The process ends 0 when the replay reaches its end.
"""

from __future__ import annotations

import argparse
import importlib
import time
from collections.abc import Callable, Sequence

from tracker_msgs_py import stop_signals
from tracker_msgs_py.node_main import (
    DEFAULT_EXECUTOR,
    EXECUTORS,
    NodeGroup,
    StartupError,
    SuiteNode,
    run_nodes,
)
from tracker_ptz_sim.bringup.graph import (
    GRAPHS,
    Graph,
    NodeSpec,
    load_graph,
    missing_topics,
    parse_overrides,
    ros_args,
    unknown_override_nodes,
    with_live_view,
)

# executable -> the node class it runs (each executable's module runs `run_node(Class)`)
NODE_CLASSES = {
    (
        "tracker_ptz_sim",
        "video_source",
    ): "tracker_ptz_sim.simulation.video_source_node:VideoSourceNode",
    ("tracker_ptz_sim", "ptz_camera"): "tracker_ptz_sim.simulation.ptz_camera_node:PtzCameraNode",
    (
        "tracker_ptz_sim",
        "ptz_controller",
    ): "tracker_ptz_sim.control.ptz_controller_node:PtzControllerNode",
    (
        "tracker_ptz_sim",
        "ptz_state_bridge",
    ): "tracker_ptz_sim.control.ptz_state_bridge_node:PtzStateBridgeNode",
    ("tracker_ptz_sim", "live_view"): "tracker_ptz_sim.bringup.live_view_node:LiveViewNode",
    ("tracker_detect", "detector"): "tracker_detect.detector_node:DetectorNode",
    ("tracker_filter", "tracker"): "tracker_filter.tracker_node:TrackerNode",
}
SOURCE = "video_source"
READY_TIMEOUT_S = 30.0
SETTLE_S = 1.0  # after the counts are met, for the other side to finish matching too


def node_class(node: NodeSpec) -> Callable[..., SuiteNode]:
    try:
        module, name = NODE_CLASSES[(node.package, node.executable)].split(":")
    except KeyError:
        raise StartupError(f"graph_host cannot run {node.package}/{node.executable}") from None
    cls: Callable[..., SuiteNode] = getattr(importlib.import_module(module), name)
    return cls


def start_graph(group: NodeGroup, graph: Graph, overrides: dict[str, dict]) -> None:
    """The processing nodes, then (once the graph is matched) the source."""

    def start(node: NodeSpec) -> None:
        arguments = ros_args(node, graph.params_files, overrides.get(node.name))
        group.add(node_class(node)(cli_args=arguments))

    for node in graph.nodes:
        if stop_signals.requested():
            return  # stopped while starting (a node loading a model takes a while): no more
        if node.name != SOURCE:
            start(node)
    probe = group.nodes[0]
    deadline = time.monotonic() + READY_TIMEOUT_S
    while not stop_signals.requested() and missing_topics(graph, probe):
        if time.monotonic() > deadline:
            raise StartupError(f"the graph's topics did not match within {READY_TIMEOUT_S:.0f} s")
        group.spin_once()
    settle = time.monotonic() + SETTLE_S
    while not stop_signals.requested() and time.monotonic() < settle:
        group.spin_once()
    if not stop_signals.requested() and any(node.name == SOURCE for node in graph.nodes):
        start(graph.node(SOURCE))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--graph", choices=list(GRAPHS), default="surveillance")
    parser.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    parser.add_argument("--live", action="store_true", help="with the live_view node")
    parser.add_argument(
        "--executor", choices=list(EXECUTORS), default=DEFAULT_EXECUTOR, help="rclpy executor"
    )
    args, ros = parser.parse_known_args(argv)
    graph = load_graph(args.graph)
    if args.live:
        graph = with_live_view(graph)
    overrides = parse_overrides(args.set)
    problem = unknown_override_nodes(overrides, [graph])
    if problem:
        parser.error(problem)
    return run_nodes(lambda group: start_graph(group, graph, overrides), ros or None, args.executor)


if __name__ == "__main__":
    raise SystemExit(main())
