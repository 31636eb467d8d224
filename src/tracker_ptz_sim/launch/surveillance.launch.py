"""ros2 launch tracker_ptz_sim surveillance.launch.py video:=/path/to/video.mp4
    [graph:=surveillance|motion|colour|standard|small_objects] [camera:=sim|live]
    [unit:=generic|flir_ptu|axis|onvif]
    [namespace:=cam1]
    [use_sim_time:=auto|true|false] [clock:=auto|global|namespaced|off]
    [controller_mode:=graph|servo|direct|hold] [respawn:=true] [live_view:=true]
    [frames_in_flight:=N] [params_file:=/path/to/my_params.yaml]
    [image_topic:=...] [camera_info_topic:=...] [joint_states_topic:=...] [command_topic:=...]
    [joint_command_topic:=...] [tf:=auto|suite|robot_state_publisher|off] [frame_prefix:=cam1/]

The whole graph, built from the same config/*graph.yaml and parameter files the demo runner
(make demo) uses, so both run exactly the same nodes with the same parameters. The surveillance
graph follows people (motion and the person model detect); graph:=motion runs its nodes without
the person model (the motion-only baseline); graph:=colour runs the colour-following graph
(motion hands its target over to CamShift; seed 001); graph:=standard the surveillance graph
behind a simulated camera that speaks only sensor_msgs, as real drivers do; graph:=small_objects
a fixed camera tracking many small movers (MOG2 + GM-PHD; seed 004).
camera:=live runs the graph behind a real unit's drivers instead of the simulator (no video);
unit:= names the driver (flir_ptu: the FLIR PTU driver's positions with speeds; axis: the Axis
driver's cmd/velocity, through axis_ptz_adapter; onvif: an ONVIF camera, through onvif_ptz, its
stream read from video:=rtsp://...) and adds its example parameter file.
Every argument wins over the parameter files, also under a namespace; two cameras run side by side
in two namespaces, each on its own clock (`tracker_ptz_sim.bringup.launch_plan` has the rules).
With respawn:=true a processing node that exits is started again (after 1 s, at most 5 times).
video_source is not respawned: it exits 0 at the end of the stream, which launch cannot tell from
a crash (`run_demo --respawn` restarts it where it left off; a source restarted from its first
frame is taken as a new replay epoch by every node). params_file:= is applied after the graph's
parameter files (the arguments above still win over it); the *_topic arguments remap the graph's
camera, joint-state and command topics in every node, for real drivers on their own names.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from tracker_ptz_sim.bringup.graph import GRAPHS, MALLOC_TUNABLES, load_graph
from tracker_ptz_sim.bringup.launch_plan import (
    CAMERAS,
    CLOCKS,
    CONTROLLER_MODES,
    SIM_TIMES,
    TF_PUBLISHERS,
    TOPIC_ARGUMENTS,
    UNITS,
    LaunchArguments,
    plan,
)

ARGUMENTS = [
    (
        "video",
        "",
        None,
        "camera:=sim: video file, image folder or rosbag2 to replay; camera:=live: the camera's "
        "stream (rtsp://...), read as its images",
    ),
    (
        "graph",
        "surveillance",
        list(GRAPHS),
        "surveillance (people: motion + the person model), motion (the motion-only baseline), "
        "colour (hands over to CamShift), standard (surveillance behind sensor_msgs-only "
        "drivers) or small_objects (a fixed camera, MOG2 + GM-PHD for many small movers)",
    ),
    (
        "camera",
        "sim",
        list(CAMERAS),
        "sim: replay video through the simulated unit; live: a "
        "real unit's drivers publish camera/* and ptz/joint_states",
    ),
    (
        "unit",
        "generic",
        list(UNITS),
        "live: the unit's driver (generic JointState velocities, flir_ptu, axis, onvif): its "
        "config/unit_<name>.yaml and adapter",
    ),
    ("namespace", "", None, "namespace of every node and topic (two cameras: two namespaces)"),
    ("use_sim_time", "auto", list(SIM_TIMES), "auto: the replay's clock for sim, wall time live"),
    (
        "clock",
        "auto",
        list(CLOCKS),
        "sim: global /clock, namespaced <namespace>/clock, or off; "
        "auto: namespaced under a namespace",
    ),
    (
        "controller_mode",
        "graph",
        list(CONTROLLER_MODES),
        "ptz_controller mode; graph: the graph's parameter files decide",
    ),
    (
        "respawn",
        "false",
        ["true", "false"],
        "restart a processing node that exits (not video_source)",
    ),
    (
        "live_view",
        "false",
        ["true", "false"],
        "serve the graph to the Foxglove app (live_view node, ws://127.0.0.1:8765)",
    ),
    (
        "frames_in_flight",
        "1",
        None,
        "sim: frames in the lockstep graph at once; the simulated camera applies each command "
        "as many frames after its image (1: in series)",
    ),
    (
        "params_file",
        "",
        None,
        "a parameter file of yours, applied after the graph's (the arguments above still win)",
    ),
    *[
        (name, "", None, f"remap the graph's {topic} to this topic in every node ('': keep)")
        for name, topic in TOPIC_ARGUMENTS.items()
    ],
    (
        "tf",
        "auto",
        ["auto", *TF_PUBLISHERS],
        "who publishes robot_description, /tf and /tf_static from ptz/joint_states: "
        "robot_state_publisher where installed (auto), else the suite's ptz_tf; or off",
    ),
    ("frame_prefix", "", None, "prefix of the unit's frame names (two cameras: cam1/, cam2/)"),
]


def _tf_publisher(choice):
    if choice != "auto":
        return choice
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_prefix
    except ImportError:
        return "suite"
    try:
        get_package_prefix("robot_state_publisher")
    except PackageNotFoundError:
        return "suite"
    return "robot_state_publisher"


def generate_launch_description():
    declared = [
        DeclareLaunchArgument(name, default_value=default, choices=choices, description=text)
        if choices
        else DeclareLaunchArgument(name, default_value=default, description=text)
        for name, default, choices, text in ARGUMENTS
    ]
    return LaunchDescription(declared + [OpaqueFunction(function=graph_actions)])


def _whole_number(name, text):
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"{name} must be a whole number, got '{text}'") from None


def graph_actions(context):
    """The nodes (and the shared-memory profile) for the arguments' values."""
    value = {name: LaunchConfiguration(name).perform(context) for name, *_ in ARGUMENTS}
    arguments = LaunchArguments(
        video=value["video"],
        graph=value["graph"],
        camera=value["camera"],
        unit=value["unit"],
        namespace=value["namespace"],
        use_sim_time=value["use_sim_time"],
        clock=value["clock"],
        controller_mode=value["controller_mode"],
        respawn=value["respawn"] == "true",
        outer_namespace=context.launch_configurations.get("ros_namespace") or "",
        live_view=value["live_view"] == "true",
        frames_in_flight=_whole_number("frames_in_flight", value["frames_in_flight"]),
        params_file=value["params_file"],
        **{name: value[name] for name in TOPIC_ARGUMENTS},
        tf=_tf_publisher(value["tf"]),
        frame_prefix=value["frame_prefix"],
    )
    respawn = {"respawn": True, "respawn_delay": 1.0, "respawn_max_retries": 5}
    nodes = [
        Node(
            package=node.package,
            executable=node.executable,
            name=node.name,
            namespace=node.namespace,  # always given: the argument dict is keyed by the full name
            parameters=[str(p) if isinstance(p, os.PathLike) else p for p in node.parameters],
            remappings=node.remappings,
            output="screen",
            **(respawn if node.respawn else {}),
        )
        for node in plan(arguments)
    ]
    # Large images need a shared-memory segment bigger than Fast DDS's default (see the profile).
    profile = load_graph(arguments.graph).config_dir / "fastdds_shm.xml"
    environment = []
    if "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ and profile.exists():
        environment.append(SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile)))
    if "GLIBC_TUNABLES" not in os.environ:  # images from the heap, not an mmap each (graph.py)
        environment.append(SetEnvironmentVariable("GLIBC_TUNABLES", MALLOC_TUNABLES))
    return environment + nodes
