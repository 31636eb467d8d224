"""Every node's decimal parameters, through the real nodes: a whole number is taken as a decimal,
a non-finite value is refused by name, at start and at run time (the shared mechanism is tested
on its own in test_tracker_msgs_py.py; this checks that every node declares through it)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from rcl_interfaces.msg import ParameterType  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from tracker_filter.tracker_node import TrackerNode  # noqa: E402
from tracker_filter.voxel_tracker_node import VoxelTrackerNode  # noqa: E402
from tracker_msgs_py.node_main import StartupError  # noqa: E402
from tracker_msgs_py.params import ParameterError  # noqa: E402
from tracker_ptz_sim.control.axis_ptz_adapter_node import AxisPtzAdapterNode  # noqa: E402
from tracker_ptz_sim.control.ptz_controller_node import PtzControllerNode  # noqa: E402
from tracker_ptz_sim.control.ptz_state_bridge_node import PtzStateBridgeNode  # noqa: E402
from tracker_ptz_sim.simulation.ptz_camera_node import PtzCameraNode  # noqa: E402
from tracker_ptz_sim.simulation.video_source_node import VideoSourceNode  # noqa: E402

pytestmark = pytest.mark.ros

NODES = [
    TrackerNode,
    VoxelTrackerNode,
    PtzControllerNode,
    PtzStateBridgeNode,
    AxisPtzAdapterNode,
    PtzCameraNode,
    VideoSourceNode,
    "detector",
]  # live_view declares only whole numbers, strings and flags


@pytest.fixture
def context():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


@pytest.fixture(scope="module")
def image_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frames")
    for k in range(2):
        cv2.imwrite(str(folder / f"{k:03d}.png"), np.full((48, 64, 3), 40 * k, np.uint8))
    return folder


def make(node_class, context, image_folder, overrides=()):
    if node_class == "detector":  # the model loads on import: only where a test needs it
        from tracker_detect.detector_node import DetectorNode

        node_class = DetectorNode
    given = list(overrides)
    if node_class is VideoSourceNode:
        given.append(Parameter("path", value=str(image_folder)))
    return node_class(context=context, parameter_overrides=given)


def decimal_parameters(node):
    """(name, value, descriptor) of the node's writable double and double-array parameters."""
    names = [name for name in node._parameters if name != "use_sim_time"]
    described = dict(zip(names, node.describe_parameters(names), strict=True))
    wanted = (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_DOUBLE_ARRAY)
    return [
        (name, node.get_parameter(name).value, d)
        for name, d in described.items()
        if d.type in wanted and not d.read_only
    ]


@pytest.mark.parametrize("node_class", NODES, ids=lambda n: n if isinstance(n, str) else n.__name__)
def test_decimal_parameters_take_whole_numbers_and_refuse_non_finite_values(
    node_class, context, image_folder
):
    node = make(node_class, context, image_folder)
    try:
        parameters = decimal_parameters(node)
        assert parameters, "a node without decimal parameters needs no entry here"
        for name, value, descriptor in parameters:
            if descriptor.type == ParameterType.PARAMETER_DOUBLE:
                for bad in (math.nan, math.inf, -math.inf):
                    result = node.set_parameters([Parameter(name, value=bad)])[0]
                    assert not result.successful and name in result.reason, (name, bad)
                if float(value).is_integer():
                    whole = node.set_parameters([Parameter(name, value=int(value))])[0]
                    assert whole.successful, (name, whole.reason)
                    assert node.get_parameter(name).value == value
                    assert isinstance(node.get_parameter(name).value, float)
            elif len(value):
                spoiled = [math.nan, *list(value)[1:]]
                result = node.set_parameters([Parameter(name, value=spoiled)])[0]
                assert not result.successful and name in result.reason, name
            assert node.get_parameter(name).value == value  # nothing refused was taken
    finally:
        node.destroy_node()


@pytest.mark.parametrize("node_class", NODES, ids=lambda n: n if isinstance(n, str) else n.__name__)
def test_a_non_finite_decimal_at_start_is_refused_by_name(node_class, context, image_folder):
    probe = make(node_class, context, image_folder)
    name = next(
        n for n, _, d in decimal_parameters(probe) if d.type == ParameterType.PARAMETER_DOUBLE
    )
    probe.destroy_node()
    with pytest.raises((ParameterError, StartupError), match=name):  # both: FATAL, exit 2
        make(node_class, context, image_folder, [Parameter(name, value=math.nan)])
