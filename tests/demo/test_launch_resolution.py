"""surveillance.launch.py's parameters as the node really gets them: the launch plan turned into
the command line launch_ros (Jazzy, launch_ros/actions/node.py) gives a node, resolved by the real
rcl and rclpy of this environment. Arguments win over the parameter files, per-node sections still
apply under a namespace, and two cameras in two namespaces keep apart."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.ros

from tracker_ptz_sim.bringup.launch_plan import LaunchArguments, PlannedNode, plan  # noqa: E402

UNSET = "<unset>"


def launch_ros_command(node: PlannedNode, tmp_path: Path, pushed: str | None = None) -> list[str]:
    """The ROS arguments launch_ros builds for a Node with a name and a namespace (so its name is
    fully specified: a parameter dict goes to a temporary file keyed by the full name), under an
    optional PushRosNamespace."""
    namespace = node.namespace
    if pushed and not namespace.startswith("/"):
        namespace = f"{pushed}/{namespace}".rstrip("/")
    namespace = "/" + namespace.lstrip("/") if not namespace.startswith("/") else namespace
    full_name = namespace.rstrip("/") + "/" + node.name
    args = ["--ros-args", "-r", f"__node:={node.name}", "-r", f"__ns:={namespace}"]
    for index, source in enumerate(node.parameters):
        if isinstance(source, dict):
            path = tmp_path / f"launch_params_{node.name}_{index}.yaml"
            path.write_text(yaml.dump({full_name: {"ros__parameters": source}}))
            source = path
        args += ["--params-file", str(source)]
    for source, target in node.remappings:
        args += ["-r", f"{source}:={target}"]
    return args


class Resolved:
    """A node started in this process with those arguments: its name, parameters and topics."""

    def __init__(self, args: list[str]) -> None:
        self.context = rclpy.Context()
        rclpy.init(args=args, context=self.context)
        # The name is the command line's: its `-r __node:=<name>` renames this node.
        self.node = rclpy.create_node("renamed_by_the_arguments", context=self.context)

    def __enter__(self) -> Resolved:
        return self

    def __exit__(self, *_) -> None:
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)

    @property
    def name(self) -> str:
        return self.node.get_fully_qualified_name()

    def value(self, name: str):  # noqa: ANN201 - a parameter value
        """The value the node's overrides (files, -p rules) give `name`, as declaring it would."""
        if self.node.has_parameter(name):
            return self.node.get_parameter(name).value
        override = self.node._parameter_overrides.get(name)
        return UNSET if override is None else override.value

    def topic(self, name: str) -> str:
        return self.node.resolve_topic_name(name)


def node(planned: list[PlannedNode], name: str) -> PlannedNode:
    return next(n for n in planned if n.name == name)


def test_arguments_win_over_the_nodes_own_sections(tmp_path):
    planned = plan(LaunchArguments(video="/data/v.avi", controller_mode="direct"))
    with Resolved(launch_ros_command(node(planned, "ptz_controller"), tmp_path)) as controller:
        assert controller.name == "/ptz_controller"
        assert controller.value("mode") == "direct"  # surveillance.yaml's section says servo
        assert controller.value("zoom_control") is True  # and its own values still apply
        assert controller.value("use_sim_time") is True
    with Resolved(launch_ros_command(node(planned, "video_source"), tmp_path)) as source:
        assert source.value("path") == "/data/v.avi" and source.value("lockstep") is True
        assert source.value("publish_clock") is True
        assert source.topic("/clock") == "/clock"


@pytest.mark.parametrize("namespace, pushed", [("cam1", None), ("", "cam1"), ("/cam1", None)])
def test_under_a_namespace_the_sections_still_match_and_the_clock_is_the_namespaces(
    tmp_path, namespace, pushed
):
    arguments = LaunchArguments(video="v.avi", namespace=namespace or "", controller_mode="direct")
    if pushed:  # an including launch file's PushRosNamespace, our namespace argument left empty
        arguments = LaunchArguments(video="v.avi", controller_mode="direct", outer_namespace=pushed)
    planned = plan(arguments)
    with Resolved(launch_ros_command(node(planned, "tracker"), tmp_path, pushed)) as tracker:
        assert tracker.name == "/cam1/tracker"
        assert tracker.value("selection_policy") == "farthest_travelled"  # its section applies
        assert tracker.topic("detections") == "/cam1/detections"
        assert tracker.topic("/clock") == "/cam1/clock"
    with Resolved(launch_ros_command(node(planned, "ptz_controller"), tmp_path, pushed)) as ctl:
        assert ctl.value("mode") == "direct"


def test_two_cameras_in_two_namespaces_keep_their_own_time_and_topics(tmp_path):
    names = set()
    clocks = set()
    for namespace in ("cam1", "cam2"):
        planned = plan(LaunchArguments(video=f"{namespace}.avi", namespace=namespace))
        with Resolved(launch_ros_command(node(planned, "video_source"), tmp_path)) as source:
            names.add(source.name)
            clocks.add(source.topic("/clock"))
            assert source.value("path") == f"{namespace}.avi"
    assert names == {"/cam1/video_source", "/cam2/video_source"}
    assert clocks == {"/cam1/clock", "/cam2/clock"}


def test_a_live_camera_runs_the_graph_behind_the_bridge_on_wall_time(tmp_path):
    planned = plan(LaunchArguments(camera="live"))
    assert [n.name for n in planned] == [
        "ptz_state_bridge",
        "ssim_detector",
        "tracker",
        "ptz_controller",
        "ptz_tf",  # the unit's TF tree from its joint states
    ]
    with Resolved(launch_ros_command(node(planned, "ssim_detector"), tmp_path)) as detector:
        assert detector.value("use_sim_time") is False
        assert detector.value("reliable_images") is False  # live cameras publish best effort
        assert detector.value("method") == "person_motion"
    with Resolved(launch_ros_command(node(planned, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("joint_command_topic") == "ptz/joint_command"


def test_unit_adds_the_drivers_parameters_and_adapter(tmp_path):
    """unit:=flir_ptu commands positions with speeds in the D46's joints; unit:=axis reads 1 Hz
    joint states at once, counts both axes the other way and speaks through axis_ptz_adapter."""
    flir = plan(LaunchArguments(camera="live", unit="flir_ptu"))
    with Resolved(launch_ros_command(node(flir, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("joint_command_style") == "positions_with_speeds"
        assert controller.value("joint_names") == ["ptu_pan", "ptu_tilt"]
        assert controller.value("joint_signs") == [1.0, -1.0]
        assert controller.value("joint_command_topic") == "ptz/joint_command"  # live.yaml's
    with Resolved(launch_ros_command(node(flir, "ptz_state_bridge"), tmp_path)) as bridge:
        assert bridge.value("pose_wait") == 0.15 and bridge.value("joint_signs") == [1.0, -1.0]
    axis = plan(LaunchArguments(camera="live", unit="axis", image_topic="/axis/image_raw"))
    assert "axis_ptz_adapter" in [n.name for n in axis]
    with Resolved(launch_ros_command(node(axis, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("joint_command_topic") == ""  # the adapter commands the camera
    with Resolved(launch_ros_command(node(axis, "ptz_state_bridge"), tmp_path)) as bridge:
        assert bridge.value("pose_wait") == 0.0 and bridge.value("max_pose_age") == 1.5
    with Resolved(launch_ros_command(node(axis, "axis_ptz_adapter"), tmp_path)) as adapter:
        assert adapter.value("joint_signs") == [-1.0, -1.0]
    remaps = dict(node(axis, "ssim_detector").remappings)
    assert remaps["camera/image_raw/compressed"] == "/axis/image_raw/compressed"
    onvif = plan(LaunchArguments(camera="live", unit="onvif", video="rtsp://cam/stream"))
    assert [n.name for n in onvif][:2] == ["video_source", "ptz_state_bridge"]
    assert "onvif_ptz" in [n.name for n in onvif]
    stream = node(onvif, "video_source")
    assert dict(stream.remappings)["scene/image_raw"] == "camera/image_raw"
    with Resolved(launch_ros_command(stream, tmp_path)) as source:
        assert source.value("path") == "rtsp://cam/stream" and source.value("lockstep") is False
    with pytest.raises(ValueError, match="camera:=live"):
        plan(LaunchArguments(video="v.avi", unit="axis"))
    with pytest.raises(ValueError, match="unit must be one of"):
        plan(LaunchArguments(camera="live", unit="sony"))


def test_the_small_objects_graph_keeps_its_fixed_camera_unless_told_otherwise(tmp_path):
    """controller_mode's default (graph) leaves the mode to the graph's files: hold for the
    small-objects graph's fixed camera, servo for the surveillance graph; a mode given wins."""
    for graph, mode in (("small_objects", "hold"), ("surveillance", "servo")):
        planned = node(plan(LaunchArguments(video="v.avi", graph=graph)), "ptz_controller")
        with Resolved(launch_ros_command(planned, tmp_path)) as controller:
            assert controller.value("mode") == mode
    planned = plan(LaunchArguments(video="v.avi", graph="small_objects", controller_mode="servo"))
    with Resolved(launch_ros_command(node(planned, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("mode") == "servo"
    with Resolved(launch_ros_command(node(planned, "detector"), tmp_path)) as detector:
        assert detector.value("method") == "mog2"
    with pytest.raises(ValueError, match="controller_mode"):
        plan(LaunchArguments(video="v.avi", controller_mode="fast"))


def test_a_wildcard_override_after_a_files_node_section_loses_to_it(tmp_path):
    """Why the plan keys its values by the node's full name: rcl applies sections in the order
    their keys first appear, so a `/**` dict (launch_ros's key when no namespace is given) loses
    to the file's node section, as the launch file of before did with controller_mode."""
    planned = node(plan(LaunchArguments(video="v.avi", controller_mode="direct")), "ptz_controller")
    files = [p for p in planned.parameters if isinstance(p, Path)]
    wildcard = tmp_path / "wildcard.yaml"
    wildcard.write_text(yaml.dump({"/**": {"ros__parameters": {"mode": "direct"}}}))
    args = ["--ros-args", "-r", "__node:=ptz_controller"]
    for path in [*files, wildcard]:
        args += ["--params-file", str(path)]
    with Resolved(args) as controller:
        assert controller.value("mode") == "servo"


def test_frames_in_flight_pipelines_the_source_and_delays_the_camera_as_many(tmp_path):
    planned = plan(LaunchArguments(video="/data/v.avi", frames_in_flight=3))
    with Resolved(launch_ros_command(node(planned, "video_source"), tmp_path)) as source:
        assert source.value("frames_in_flight") == 3 and source.value("lockstep") is True
    with Resolved(launch_ros_command(node(planned, "ptz_camera"), tmp_path)) as camera:
        assert camera.value("command_delay_frames") == 3
    in_series = plan(LaunchArguments(video="/data/v.avi"))
    with Resolved(launch_ros_command(node(in_series, "ptz_camera"), tmp_path)) as camera:
        assert camera.value("command_delay_frames") == UNSET  # the node's default, 1


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="video:="):
        plan(LaunchArguments())
    with pytest.raises(ValueError, match="frames_in_flight must be in"):
        plan(LaunchArguments(video="v.avi", frames_in_flight=0))
    with pytest.raises(ValueError, match="camera must be one of sim, live"):
        plan(LaunchArguments(camera="usb"))
    with pytest.raises(ValueError, match="needs a clock"):
        plan(LaunchArguments(video="v.avi", clock="off", use_sim_time="true"))
    with pytest.raises(ValueError, match="tf must be one of"):
        plan(LaunchArguments(video="v.avi", tf="tf2"))
    with pytest.raises(ValueError, match="params_file: no such file"):
        plan(LaunchArguments(video="v.avi", params_file="/no/such.yaml"))


def test_a_params_file_of_ones_own_wins_over_the_graphs_and_the_arguments_over_it(tmp_path):
    mine = tmp_path / "mine.yaml"
    mine.write_text(
        yaml.dump(
            {
                "/**/ptz_controller": {"ros__parameters": {"kp": 2.5, "mode": "hold"}},
                "/**": {"ros__parameters": {"reliable_images": False}},
            }
        )
    )
    planned = plan(LaunchArguments(video="v.avi", params_file=str(mine)))
    with Resolved(launch_ros_command(node(planned, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("kp") == 2.5 and controller.value("mode") == "hold"
    argued = plan(LaunchArguments(video="v.avi", params_file=str(mine), controller_mode="direct"))
    with Resolved(launch_ros_command(node(argued, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("mode") == "direct" and controller.value("kp") == 2.5
    with Resolved(launch_ros_command(node(planned, "ssim_detector"), tmp_path)) as detector:
        assert detector.value("reliable_images") is False  # the graph's files say true


def test_topic_arguments_remap_the_camera_joint_and_command_topics_in_every_node(tmp_path):
    arguments = LaunchArguments(
        camera="live",
        namespace="cam1",
        image_topic="/axis/image_raw",
        camera_info_topic="/axis/camera_info",
        joint_states_topic="/axis/joint_states",
        joint_command_topic="ptu/cmd",
    )
    planned = plan(arguments)
    with Resolved(launch_ros_command(node(planned, "ssim_detector"), tmp_path)) as detector:
        assert detector.topic("camera/image_raw") == "/axis/image_raw"
        assert detector.topic("camera/camera_info") == "/axis/camera_info"
        assert detector.topic("ptz/state") == "/cam1/ptz/state"  # not remapped
    with Resolved(launch_ros_command(node(planned, "ptz_state_bridge"), tmp_path)) as bridge:
        assert bridge.topic("ptz/joint_states") == "/axis/joint_states"
    with Resolved(launch_ros_command(node(planned, "ptz_controller"), tmp_path)) as controller:
        assert controller.topic("ptz/joint_command") == "/cam1/ptu/cmd"
        assert controller.topic("ptz/command") == "/cam1/ptz/command"


def test_the_tf_publisher_and_the_frame_prefix(tmp_path):
    """The suite's ptz_tf, or robot_state_publisher on the unit's URDF reading ptz/joint_states;
    a frame prefix renames the camera's image frame and the commands' frame too."""
    suite = plan(LaunchArguments(video="v.avi", frame_prefix="cam1/", namespace="cam1"))
    with Resolved(launch_ros_command(node(suite, "ptz_tf"), tmp_path)) as tf:
        assert tf.value("frame_prefix") == "cam1/" and tf.topic("ptz/joint_states") == (
            "/cam1/ptz/joint_states"
        )
    with Resolved(launch_ros_command(node(suite, "ptz_camera"), tmp_path)) as camera:
        assert camera.value("camera_frame_id") == "cam1/ptz_camera_optical"
    with Resolved(launch_ros_command(node(suite, "ptz_controller"), tmp_path)) as controller:
        assert controller.value("base_frame_id") == "cam1/ptz_base"
    standard = plan(LaunchArguments(video="v.avi", tf="robot_state_publisher"))
    publisher = node(standard, "robot_state_publisher")
    assert publisher.package == "robot_state_publisher"
    with Resolved(launch_ros_command(publisher, tmp_path)) as rsp:
        assert rsp.topic("joint_states") == "/ptz/joint_states"
        assert '<joint name="pan_joint" type="revolute">' in rsp.value("robot_description")
    assert all(
        n.name not in ("ptz_tf", "robot_state_publisher")
        for n in plan(LaunchArguments(video="v.avi", tf="off"))
    )
