"""What surveillance.launch.py starts for its arguments (no rclpy, no launch): one place that turns
the launch arguments into nodes, so the launch file stays a thin shell and its rules are testable.

- `camera:=sim` runs the graph as the demo does (video_source replays `video`, ptz_camera
  simulates the unit); `camera:=live` replaces both by `ptz_state_bridge` in front of a real unit's
  drivers (the README's "On a real pan-tilt unit"), with config/live.yaml (wall time, best-effort
  images, JointState commands on ptz/joint_command).
- `unit` (live): the driver behind the graph: `generic` (JointState velocities), `flir_ptu` (the
  FLIR PTU driver: config/unit_flir_ptu.yaml, positions with speeds on its `cmd`), `axis` (the
  Axis driver: config/unit_axis.yaml and `axis_ptz_adapter` onto its `cmd/velocity`) or `onvif`
  (an ONVIF camera: config/unit_onvif.yaml and `onvif_ptz`), applied after live.yaml and before
  `params_file`. With camera:=live, `video` (an rtsp:// URL) is read by video_source as the
  camera's images (`camera/image_raw`, `camera/camera_info`).
- Every node gets `namespace` (default: none), so two cameras run side by side in two namespaces;
  the per-node sections of the parameter files are keyed `/**/<name>` and match under any.
- The arguments always win: each node gets them last, in a dict `launch_ros` writes under the
  node's fully qualified name (the namespace is always given, so the name is fully specified) --
  a key that first appears after the files' sections, which rcl then applies last
  (`graph.resolve_parameters` states the rules).
- `use_sim_time` (`auto`: on for sim unless the clock is off, off for live) and `clock`: `global`
  publishes `/clock`; `namespaced` remaps every node's `/clock` to `<namespace>/clock`, so two
  simulated cameras do not drive each other's time; `off` publishes none. `auto`: namespaced
  when a namespace is given or pushed by an including launch file, else global.
- `controller_mode` (`graph`: as the graph's parameter files say, servo in the surveillance,
  colour and standard graphs, hold in small_objects) sets ptz_controller's `mode`.
- `live_view:=true` adds the Foxglove live view (`live_view` node, ws://127.0.0.1:8765).
- `frames_in_flight` (sim): a lockstep replay with that many frames in the graph at once, the
  simulated camera applying each command as many frames after its image (`graph.pipelined`).
- `params_file`: a parameter file of the user's, applied after the graph's files (its sections win
  over theirs; the arguments above still win over it).
- `tf` (`suite`: the suite's `ptz_tf`; `robot_state_publisher`: that, on the URDF; `off`) publishes
  `robot_description`, `/tf_static` and `/tf` from `ptz/joint_states`, every frame under
  `frame_prefix` (the camera's images and the controller's commands take the prefixed names too).
- `image_topic`, `camera_info_topic`, `joint_states_topic`, `command_topic`,
  `joint_command_topic`: remap the graph's `camera/image_raw`, `camera/camera_info`,
  `ptz/joint_states`, `ptz/command` and `ptz/joint_command` in every node, so the graph meets a
  real unit's drivers on their own topics.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tracker_ptz_sim.bringup.graph import Graph, NodeSpec, load_graph, pipelined, with_live_view
from tracker_ptz_sim.control.pan_tilt_frames import PanTiltFrames

CAMERAS = ("sim", "live")
TF_PUBLISHERS = ("suite", "robot_state_publisher", "off")
CLOCKS = ("auto", "global", "namespaced", "off")
SIM_TIMES = ("auto", "true", "false")
CONTROLLER_MODES = ("graph", "servo", "direct", "hold")  # graph: the graph's own
SIMULATOR_NODES = ("video_source", "ptz_camera")
BRIDGE = NodeSpec("tracker_ptz_sim", "ptz_state_bridge", "ptz_state_bridge")
LIVE_PARAMETERS = "live.yaml"  # in the graph's config directory
UNITS = ("generic", "flir_ptu", "axis", "onvif")  # parameters: unit_<name>.yaml, by live.yaml
#: Nodes a unit's driver needs in front of it.
UNIT_ADAPTERS = {
    "axis": NodeSpec("tracker_ptz_sim", "axis_ptz_adapter", "axis_ptz_adapter"),
    "onvif": NodeSpec("tracker_ptz_sim", "onvif_ptz", "onvif_ptz"),
}
#: A live camera's stream read by video_source (`video:=rtsp://...`) as the camera's images.
LIVE_STREAM = NodeSpec(
    "tracker_ptz_sim",
    "video_source",
    "video_source",
    {"scene/image_raw": "camera/image_raw", "scene/camera_info": "camera/camera_info"},
)


@dataclass(frozen=True)
class LaunchArguments:
    video: str = ""
    graph: str = "surveillance"
    camera: str = "sim"
    unit: str = "generic"  # live: the driver behind the graph (UNITS)
    namespace: str = ""
    use_sim_time: str = "auto"
    clock: str = "auto"
    controller_mode: str = "graph"  # or a ptz_controller mode
    respawn: bool = False
    outer_namespace: str = ""  # pushed by an including launch file (PushRosNamespace)
    live_view: bool = False  # serve the graph to the Foxglove app
    frames_in_flight: int = 1  # lockstep replay: frames in the graph at once
    params_file: str = ""  # the user's parameter file, after the graph's
    image_topic: str = ""  # remaps of the graph's topics ("": the graph's own name)
    camera_info_topic: str = ""
    joint_states_topic: str = ""
    command_topic: str = ""
    joint_command_topic: str = ""
    tf: str = "suite"  # who publishes the unit's TF tree: suite, robot_state_publisher or off
    frame_prefix: str = ""  # of every frame of the unit ("cam1/")


#: The LaunchArguments fields that remap a graph topic, and the topic each one renames.
TOPIC_ARGUMENTS = {
    "image_topic": "camera/image_raw",
    "camera_info_topic": "camera/camera_info",
    "joint_states_topic": "ptz/joint_states",
    "command_topic": "ptz/command",
    "joint_command_topic": "ptz/joint_command",
}


@dataclass(frozen=True)
class PlannedNode:
    """A launch_ros Node's arguments."""

    package: str
    executable: str
    name: str
    namespace: str
    parameters: list[Path | dict[str, Any]]  # files in order, then the arguments' values
    remappings: list[tuple[str, str]] = field(default_factory=list)
    respawn: bool = False


def plan(arguments: LaunchArguments, graph: Graph | None = None) -> list[PlannedNode]:
    """The nodes to start; raises ValueError naming a bad argument."""
    _check(arguments)
    graph = graph or load_graph(arguments.graph)
    if arguments.live_view:
        graph = with_live_view(graph)
    live = arguments.camera == "live"
    nodes = _live_nodes(graph, arguments.unit, arguments.video) if live else list(graph.nodes)
    files: list[Path] = list(graph.params_files)
    if live:
        files.append(graph.config_dir / LIVE_PARAMETERS)
        if arguments.unit != "generic":
            files.append(graph.config_dir / f"unit_{arguments.unit}.yaml")
    if arguments.params_file:
        files.append(Path(arguments.params_file))
    clock = _clock(arguments)
    sim_time = _sim_time(arguments, clock)
    planned = []
    for node in nodes:
        values: dict[str, Any] = {"use_sim_time": sim_time}
        if node.name == "video_source":
            values |= {"path": arguments.video, "publish_clock": clock != "off"}
        if node.name == "ptz_controller" and arguments.controller_mode != "graph":
            values["mode"] = arguments.controller_mode
        if arguments.frames_in_flight != 1:
            values |= pipelined(arguments.frames_in_flight).get(node.name, {})
        values |= _prefixed_frames(arguments.frame_prefix).get(node.name, {})
        remappings = list(node.remappings.items()) + _topic_remappings(arguments)
        if clock == "namespaced":
            remappings.append(("/clock", "clock"))  # relative: <namespace>/clock
        planned.append(
            PlannedNode(
                node.package,
                node.executable,
                node.name,
                arguments.namespace,
                [*files, values],
                remappings,
                respawn=arguments.respawn and node.name != "video_source",
            )
        )
    tf_node = _tf_node(arguments, sim_time, files)
    return planned + ([tf_node] if tf_node else [])


def _prefixed_frames(prefix: str) -> dict[str, dict[str, str]]:
    if not prefix:
        return {}
    frames = PanTiltFrames(prefix)
    return {
        "ptz_camera": {"camera_frame_id": frames.optical},
        "ptz_controller": {"base_frame_id": frames.base, "optical_frame_id": frames.optical},
    }


def _tf_node(arguments: LaunchArguments, sim_time: bool, files: list[Path]) -> PlannedNode | None:
    """The unit's TF publisher: the suite's ptz_tf, or robot_state_publisher on its URDF; with
    the graph's files (and yours) like every node."""
    if arguments.tf == "off":
        return None
    values: dict[str, Any] = {"use_sim_time": sim_time}
    if arguments.tf == "robot_state_publisher":
        values["robot_description"] = PanTiltFrames(arguments.frame_prefix).urdf()
        package = executable = "robot_state_publisher"
        remappings = [("joint_states", arguments.joint_states_topic or "ptz/joint_states")]
    else:
        values["frame_prefix"] = arguments.frame_prefix
        package, executable = "tracker_ptz_sim", "ptz_tf"
        remappings = _topic_remappings(arguments)
    parameters: list[Path | dict[str, Any]] = [*files, values]
    return PlannedNode(
        package, executable, executable, arguments.namespace, parameters, remappings,
        arguments.respawn,
    )  # fmt: skip


def _topic_remappings(arguments: LaunchArguments) -> list[tuple[str, str]]:
    given = {name: getattr(arguments, name) for name in TOPIC_ARGUMENTS}
    remaps = [(TOPIC_ARGUMENTS[name], topic) for name, topic in given.items() if topic]
    if arguments.image_topic:  # image_transport's compressed stream rides along (Axis's images)
        remaps.append(("camera/image_raw/compressed", arguments.image_topic + "/compressed"))
    return remaps


def _check(arguments: LaunchArguments) -> None:
    _check_choice(arguments, "camera", CAMERAS)
    _check_choice(arguments, "unit", UNITS)
    if arguments.unit != "generic" and arguments.camera != "live":
        raise ValueError(f"unit:={arguments.unit} drives a real unit: it needs camera:=live")
    _check_choice(arguments, "tf", TF_PUBLISHERS)
    _check_choice(arguments, "clock", CLOCKS)
    _check_choice(arguments, "controller_mode", CONTROLLER_MODES)
    _check_choice(arguments, "use_sim_time", SIM_TIMES)
    pipelined(arguments.frames_in_flight)  # raises for a count out of range
    if arguments.params_file and not Path(arguments.params_file).is_file():
        raise ValueError(f"params_file: no such file '{arguments.params_file}'")
    if arguments.camera == "sim" and not arguments.video:
        raise ValueError("camera:=sim replays a recording: give video:=/path/to/video")
    if arguments.use_sim_time == "true" and _clock(arguments) == "off":
        raise ValueError("use_sim_time:=true needs a clock: clock:=off (or camera:=live) has none")


def _check_choice(arguments: LaunchArguments, name: str, choices: tuple[str, ...]) -> None:
    """Raise unless the argument `name` is one of `choices`."""
    value = getattr(arguments, name)
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}, got '{value}'")


def _clock(arguments: LaunchArguments) -> str:
    if arguments.camera == "live":
        return "off"  # no replay: nothing publishes /clock
    if arguments.clock == "auto":
        namespaced = arguments.namespace.strip("/") or arguments.outer_namespace.strip("/")
        return "namespaced" if namespaced else "global"
    return arguments.clock


def _sim_time(arguments: LaunchArguments, clock: str) -> bool:
    if arguments.use_sim_time == "auto":
        return clock != "off"
    return arguments.use_sim_time == "true"


def _live_nodes(graph: Graph, unit: str, video: str) -> list[NodeSpec]:
    """The graph without the simulator, behind the bridge to a real unit's drivers (and the
    adapter its driver needs); with `video`, video_source reads that stream as the camera's
    images (an IP camera's RTSP)."""
    kept = [node for node in graph.nodes if node.name not in SIMULATOR_NODES]
    if all(node.name != BRIDGE.name for node in kept):
        kept.insert(0, BRIDGE)
    adapter = UNIT_ADAPTERS.get(unit)
    stream = [LIVE_STREAM] if video else []
    return stream + kept + ([adapter] if adapter else [])
