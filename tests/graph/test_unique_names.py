"""Names that cannot collide: in every shipped graph each service has one server and each topic
one publisher (ROS does not define which of two servers answers, and two publishers of one
result interleave). The nodes are built as the graph builds them (its params files, names and
remappings) and their own publishers and services are listed."""

from __future__ import annotations

from collections import defaultdict

import cv2
import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from tracker_ptz_sim.bringup.graph import GRAPHS, load_graph, ros_args  # noqa: E402
from tracker_ptz_sim.bringup.graph_host import SOURCE, node_class  # noqa: E402

pytestmark = pytest.mark.ros
# Shared by design: every node reports on /diagnostics and logs on /rosout; rclpy's own.
SHARED = {"/diagnostics", "/rosout", "/parameter_events"}


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clip")
    for k in range(2):
        cv2.imwrite(str(folder / f"{k:03d}.png"), np.full((240, 320, 3), 60 + k, np.uint8))
    return folder


def graph_names(graph_name, clip):
    """{topic: [publishing nodes]}, {service: [serving nodes]} of the graph's nodes."""
    graph = load_graph(graph_name)
    context = rclpy.Context()
    rclpy.init(context=context)
    publishers, servers = defaultdict(list), defaultdict(list)
    nodes = []
    try:
        for spec in graph.nodes:
            overrides = {"path": str(clip)} if spec.name == SOURCE else None
            arguments = ros_args(spec, graph.params_files, overrides)
            node = node_class(spec)(cli_args=arguments, context=context)
            nodes.append(node)
            for publisher in node.publishers:
                publishers[publisher.topic_name].append(spec.name)
            for service in node.services:
                servers[node.resolve_service_name(service.srv_name)].append(spec.name)
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.shutdown(context=context)
    return publishers, servers


@pytest.mark.parametrize("graph_name", list(GRAPHS))
def test_every_service_has_one_server_and_every_topic_one_publisher(graph_name, clip):
    publishers, servers = graph_names(graph_name, clip)
    shared_services = {name: who for name, who in servers.items() if len(who) > 1}
    assert not shared_services, f"served by more than one node: {shared_services}"
    shared_topics = {t: who for t, who in publishers.items() if len(who) > 1 and t not in SHARED}
    assert not shared_topics, f"published by more than one node: {shared_topics}"
    assert "/ptz/command" in publishers and "/target" in publishers
    suite_services = {name for name in servers if "parameter" not in name}
    if graph_name == "colour":  # two trackers and two detectors, each under its own name
        assert {"/tracker/select_target", "/colour_tracker/select_target"} <= suite_services
        assert {"/ssim_detector/select_region", "/colour_detector/select_region"} <= suite_services
