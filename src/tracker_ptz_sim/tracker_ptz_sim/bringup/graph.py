"""The graph descriptions (config/*graph.yaml and the parameter files they name), no rclpy.

One place defines which nodes run, their names, remappings and parameters; the demo runner turns
it into processes started from the install space, the launch file into launch_ros Node actions.
Graphs (`GRAPHS`): `surveillance` (config/graph.yaml: motion and the person model detect, people
are tracked, the camera follows a person), `motion` (config/motion_graph.yaml: the same nodes
without the person model, the motion-only baseline) and `colour` (config/colour_graph.yaml: the
motion-only pipeline on motion/* topics hands its target over to CamShift, whose own tracker the
camera follows),
`standard` (config/standard_graph.yaml: surveillance behind sensor_msgs-only drivers) and
`small_objects` (config/small_objects_graph.yaml: a fixed camera showing the whole scene, MOG2
background subtraction and the GM-PHD tracker for many small movers; seed 004).
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from tracker_msgs_py.package_files import package_data
from tracker_msgs_py.params import flatten_parameters
from tracker_ptz_sim.simulation.camera_model import MAX_COMMAND_DELAY_FRAMES


@dataclass(frozen=True)
class NodeSpec:
    package: str
    executable: str
    name: str
    remappings: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class TopicSpec:
    name: str
    type: str  # e.g. "sensor_msgs/msg/Image"


@dataclass(frozen=True)
class Graph:
    name: str
    nodes: list[NodeSpec]
    topics: list[TopicSpec]
    params_files: tuple[Path, ...]  # in order: a later file's values win
    ready: dict[str, int]  # topic -> subscribers (the recorder included) before the first frame

    @property
    def config_dir(self) -> Path:
        return self.params_files[0].parent

    def node(self, name: str) -> NodeSpec:
        for node in self.nodes:
            if node.name == name:
                return node
        raise KeyError(f"no node '{name}' in the graph")


def config_dir() -> Path:
    """The package's config/ directory."""
    return package_data("tracker_ptz_sim", "config")


#: glibc malloc settings for the graph's processes: blocks up to 4 MB (a 768x576 bgr8 image is
#: 1.3 MB) come from the heap instead of a fresh mmap, and freed heap is kept, so an image costs no
#: page faults. Measured with bench_graph on vtest.avi: 37.8 -> 45.7 frames/s. glibc reads it
#: when a process starts: scripts/env.sh exports it, the runner and the launch file set it for
#: the nodes.
MALLOC_TUNABLES = "glibc.malloc.mmap_threshold=4194304:glibc.malloc.trim_threshold=134217728"

#: The Foxglove live view (bringup/live_view_node.py), added to any graph on request.
LIVE_VIEW = NodeSpec("tracker_ptz_sim", "live_view", "live_view")


def with_live_view(graph: Graph) -> Graph:
    """The graph plus the live view node (run_demo --live, surveillance.launch.py live_view:=true)."""
    if any(node.name == LIVE_VIEW.name for node in graph.nodes):
        return graph
    return replace(graph, nodes=[*graph.nodes, LIVE_VIEW])


def without_nodes(graph: Graph, names: set[str]) -> Graph:
    """The graph without the named nodes (they run elsewhere); its topics and readiness counts
    stay, so a runner still waits for them to be discovered."""
    return replace(graph, nodes=[node for node in graph.nodes if node.name not in names])


#: Graph name -> its description file in config/.
GRAPHS = {
    "surveillance": "graph.yaml",
    "motion": "motion_graph.yaml",
    "colour": "colour_graph.yaml",
    "standard": "standard_graph.yaml",
    "small_objects": "small_objects_graph.yaml",
}


def load_graph(name: str = "surveillance", directory: Path | None = None) -> Graph:
    if name not in GRAPHS:
        raise ValueError(f"no graph '{name}' (graphs: {', '.join(GRAPHS)})")
    directory = directory or config_dir()
    data = yaml.safe_load((directory / GRAPHS[name]).read_text())
    nodes = [
        NodeSpec(n["package"], n["executable"], n["name"], dict(n.get("remappings") or {}))
        for n in data["nodes"]
    ]
    topics = [TopicSpec(t["name"], t["type"]) for t in data["topics"]]
    files = tuple(directory / f for f in data["parameters"])
    return Graph(name, nodes, topics, files, {k: int(v) for k, v in data["ready"].items()})


def missing_topics(graph: Graph, node: Any) -> dict[str, int]:
    """The topics of `graph.ready` that `node` (any rclpy node) does not yet see with a publisher
    and the subscribers they need, with the subscribers needed."""
    return {
        topic: wanted
        for topic, wanted in graph.ready.items()
        if node.count_publishers(topic) == 0 or node.count_subscribers(topic) < wanted
    }


def node_parameters(params_files: Path | Sequence[Path], node_name: str) -> dict[str, Any]:
    """The parameters ROS params files give the node `/node_name` (`resolve_parameters`)."""
    files = [params_files] if isinstance(params_files, Path) else list(params_files)
    return resolve_parameters(files, "/" + node_name)


ParameterSource = Path | Mapping[str, Any]  # a params file, or its content as a dict


def resolve_parameters(sources: Sequence[ParameterSource], node_fqn: str) -> dict[str, Any]:
    """The parameters the node `node_fqn` gets from params files (or dicts of the same shape,
    `{pattern: {"ros__parameters": {...}}}`), resolved as rcl and rclpy do:

    - each section's key is a node-name pattern: `/**` matches any namespaces, `/*` one, a key
      without a leading `/` gets one (`ptz_controller` matches only `/ptz_controller`; write
      `/**/ptz_controller` to match it under any namespace);
    - sections are kept in the order their key first appears over all sources; a later source's
      values for the same key overwrite the earlier ones in place;
    - the node gets every matching section's values, merged in that order (a later section wins).
    So a `/**` override given after a file whose node-specific section sets the same parameter
    loses to that section (its key appeared first); a key for the node's own name, appearing
    later, wins.
    """
    sections: dict[str, dict[str, Any]] = {}
    for source in sources:
        data = yaml.safe_load(source.read_text()) if isinstance(source, Path) else source
        for key, body in (data or {}).items():
            values = flatten_parameters((body or {}).get("ros__parameters", {}))
            sections.setdefault(str(key), {}).update(values)
    merged: dict[str, Any] = {}
    for key, values in sections.items():
        pattern = key if key.startswith("/") else "/" + key
        if re.fullmatch(pattern.replace("/*", r"(/\w+)"), node_fqn):
            merged.update(values)
    return merged


def ros_args(
    node: NodeSpec, params_files: Sequence[Path], overrides: dict[str, Any] | None = None
) -> list[str]:
    """The `--ros-args ...` of one node process: name, params files, overrides, remappings."""
    args = ["--ros-args", "-r", f"__node:={node.name}"]
    for path in params_files:
        args += ["--params-file", str(path)]
    for key, value in (overrides or {}).items():
        # Node-qualified: a plain -p is a /** override, which the params file's node section beats.
        args += ["-p", f"{node.name}:{key}:={format_value(value)}"]
    for source, target in node.remappings.items():
        args += ["-r", f"{source}:={target}"]
    return args


def format_value(value: Any) -> str:
    """A parameter value as the command line's YAML expects it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | tuple):
        return "[" + ",".join(format_value(v) for v in value) + "]"
    if isinstance(value, str):
        return yaml.safe_dump(value, default_style='"').strip() if value == "" else value
    return str(value)


def executable_path(install_dir: Path, node: NodeSpec) -> Path:
    """install/<package>/lib/<package>/<executable>, what `ros2 run` executes."""
    path = install_dir / node.package / "lib" / node.package / node.executable
    if not os.access(path, os.X_OK):
        raise FileNotFoundError(f"{path} is missing: build the workspace first (make setup)")
    return path


NODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")


def parse_overrides(items: Sequence[str]) -> dict[str, dict[str, Any]]:
    """--set node.param=value, or node.param:=value as ROS launch writes it (values parsed as
    YAML: 0.5, true, [1, 2], text; nothing after the `=` is the empty string, e.g. a topic
    turned off, not YAML's null). SystemExit naming the item for anything else."""
    overrides: dict[str, dict[str, Any]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        node, dot, param = key.removesuffix(":").partition(".")
        if not sep or not dot:
            raise SystemExit(f"--set expects node.param=value, got '{item}'")
        if not NODE_NAME.fullmatch(node) or not PARAMETER_NAME.fullmatch(param):
            raise SystemExit(
                f"--set '{item}': '{node}.{param}' is not a node name and a parameter name "
                "(letters, digits and underscores; dots between a parameter's parts)"
            )
        overrides.setdefault(node, {})[param] = yaml.safe_load(value) if value.strip() else ""
    return overrides


def pipelined(frames_in_flight: int) -> dict[str, dict[str, Any]]:
    """Overrides for a lockstep replay with `frames_in_flight` frames in flight: the source runs
    that many frames ahead of the acknowledgements, and the camera applies each command that many
    frames after the image it answers, so the replay stays deterministic. ValueError, naming the
    range, for a count the camera cannot delay by."""
    if not 1 <= frames_in_flight <= MAX_COMMAND_DELAY_FRAMES:
        raise ValueError(
            f"frames_in_flight must be in [1, {MAX_COMMAND_DELAY_FRAMES}], got {frames_in_flight}"
        )
    return {
        "video_source": {"frames_in_flight": frames_in_flight},
        "ptz_camera": {"command_delay_frames": frames_in_flight},
    }


def unknown_override_nodes(overrides: Mapping[str, Any], graphs: Iterable[Graph]) -> str | None:
    """Why --set `overrides` name a node that none of `graphs` runs (its values would change
    nothing: a misspelt node name), or None when every node is there."""
    names = {node.name for graph in graphs for node in graph.nodes}
    unknown = sorted(set(overrides) - names)
    if not unknown:
        return None
    return (
        f"--set: no node {', '.join(unknown)} in the graph (its nodes: {', '.join(sorted(names))})"
    )


def override_arguments(overrides: dict[str, dict[str, Any]]) -> list[str]:
    """The --set arguments that `parse_overrides` reads back as `overrides`."""
    return [
        f"--set={node}.{name}={format_value(value)}"
        for node, values in overrides.items()
        for name, value in values.items()
    ]
