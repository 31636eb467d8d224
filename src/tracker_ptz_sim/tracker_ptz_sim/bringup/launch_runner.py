"""run_launch: runs the suite's launch files where `ros2 launch` is not installed (the PyPI wheels
have no launch, launch_ros or ros2cli).

    run_launch tracker_ptz_sim surveillance.launch.py video:=/path/to/video.mp4 [name:=value ...]
    run_launch --print tracker_ptz_sim surveillance.launch.py ...   (the commands, and exit)

It executes the launch file itself, with a small implementation of the part of launch's and
launch_ros's API the suite's launch files use (`LaunchDescription`, `DeclareLaunchArgument` with
defaults and choices, `LaunchConfiguration`, `OpaqueFunction`, `SetEnvironmentVariable`, and
launch_ros's `Node`: name, namespace, parameter files and dicts, remappings, respawn). Each node
runs as its own process with the command line launch_ros gives it (`node_command`), its output on
this terminal. Ctrl-C stops them all (SIGINT, then SIGTERM after 5 s); it exits when every
process has ended: 0 when each ended 0 or by the stop, else 1. The parameter files it writes for
the nodes (launch_ros's dicts) go with it; `--print` keeps them, for the commands it prints.
Where ROS comes from apt, use `ros2 launch`, which reads the same files.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import types
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from tracker_msgs_py import stop_signals
from tracker_ptz_sim.bringup.graph import NodeSpec, executable_path

STOP_WAIT_S = 5.0  # after SIGINT, before SIGTERM


# --- the launch API subset ------------------------------------------------------------------------


class LaunchContext:
    """What an OpaqueFunction sees: the launch arguments' values."""

    def __init__(self, configurations: dict[str, str]) -> None:
        self.launch_configurations = configurations


class LaunchConfiguration:
    def __init__(self, name: str) -> None:
        self.name = name

    def perform(self, context: LaunchContext) -> str:
        return context.launch_configurations[self.name]


@dataclass
class DeclareLaunchArgument:
    name: str
    default_value: str | None = None
    description: str = ""
    choices: Sequence[str] | None = None


@dataclass
class OpaqueFunction:
    function: Callable[[LaunchContext], list[Any] | None]


@dataclass
class SetEnvironmentVariable:
    name: str
    value: str


@dataclass
class Node:
    """launch_ros.actions.Node's arguments (the ones the suite's launch files pass)."""

    package: str
    executable: str
    name: str | None = None
    namespace: str = ""
    parameters: Sequence[Any] = ()
    remappings: Sequence[tuple[str, str]] = ()
    output: str = "screen"
    respawn: bool = False
    respawn_delay: float = 0.0
    respawn_max_retries: int = -1
    arguments: Sequence[str] = ()


class LaunchDescription:
    def __init__(self, entities: Sequence[Any] = ()) -> None:
        self.entities = list(entities)


def _api_modules() -> dict[str, types.ModuleType]:
    """The modules `import launch` / `launch_ros.actions` give the launch file."""
    launch = types.ModuleType("launch")
    actions = types.ModuleType("launch.actions")
    substitutions = types.ModuleType("launch.substitutions")
    launch_ros = types.ModuleType("launch_ros")
    ros_actions = types.ModuleType("launch_ros.actions")
    launch.LaunchDescription = LaunchDescription  # type: ignore[attr-defined]
    launch.actions, launch.substitutions = actions, substitutions  # type: ignore[attr-defined]
    actions.DeclareLaunchArgument = DeclareLaunchArgument  # type: ignore[attr-defined]
    actions.OpaqueFunction = OpaqueFunction  # type: ignore[attr-defined]
    actions.SetEnvironmentVariable = SetEnvironmentVariable  # type: ignore[attr-defined]
    substitutions.LaunchConfiguration = LaunchConfiguration  # type: ignore[attr-defined]
    ros_actions.Node = Node  # type: ignore[attr-defined]
    launch_ros.actions = ros_actions  # type: ignore[attr-defined]
    return {
        "launch": launch,
        "launch.actions": actions,
        "launch.substitutions": substitutions,
        "launch_ros": launch_ros,
        "launch_ros.actions": ros_actions,
    }


def load_description(path: Path) -> LaunchDescription:
    """The launch file's `generate_launch_description()`, run against this module's API."""
    saved = {name: sys.modules.get(name) for name in _api_modules()}
    sys.modules.update(_api_modules())
    try:
        spec = importlib.util.spec_from_file_location(f"launch_file_{path.stem}", path)
        if spec is None or spec.loader is None:
            raise ValueError(f"{path} is not a Python launch file")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        description: LaunchDescription = module.generate_launch_description()
        return description
    finally:
        for name, module_before in saved.items():
            if module_before is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = module_before


# --- from a description to processes --------------------------------------------------------------


@dataclass
class Plan:
    environment: dict[str, str] = field(default_factory=dict)
    nodes: list[Node] = field(default_factory=list)


def resolve(description: LaunchDescription, given: dict[str, str]) -> Plan:
    """The environment and nodes for the arguments `given` (name -> value); ValueError naming an
    unknown argument, a value outside an argument's choices or a required one missing."""
    declared = [e for e in description.entities if isinstance(e, DeclareLaunchArgument)]
    names = {argument.name for argument in declared}
    unknown = sorted(given.keys() - names)
    if unknown:
        raise ValueError(f"unknown launch argument(s) {unknown}; the file takes {sorted(names)}")
    values: dict[str, str] = {}
    for argument in declared:
        value = given.get(argument.name, argument.default_value)
        if value is None:
            raise ValueError(f"launch argument '{argument.name}' is required")
        if argument.choices and value not in argument.choices:
            raise ValueError(
                f"launch argument '{argument.name}' must be one of {list(argument.choices)}, "
                f"got '{value}'"
            )
        values[argument.name] = value
    plan = Plan()
    _collect(description.entities, LaunchContext(values), plan)
    return plan


def _collect(entities: Sequence[Any], context: LaunchContext, plan: Plan) -> None:
    for entity in entities:
        if isinstance(entity, OpaqueFunction):
            _collect(entity.function(context) or [], context, plan)
        elif isinstance(entity, SetEnvironmentVariable):
            plan.environment[entity.name] = entity.value
        elif isinstance(entity, Node):
            plan.nodes.append(entity)
        elif not isinstance(entity, DeclareLaunchArgument):
            raise ValueError(f"run_launch cannot run a {type(entity).__name__} (use ros2 launch)")


def node_command(node: Node, executable: Path, scratch: Path) -> list[str]:
    """The command launch_ros (Jazzy, launch_ros/actions/node.py) runs for `node`: its name and
    namespace remaps, each parameter file (a dict written to one keyed by the node's full name, or
    `/**` when the name is not fully given), then its remappings."""
    namespace = "/" + node.namespace.strip("/") if node.namespace else ""
    args = [str(executable), *node.arguments, "--ros-args"]
    if node.name:
        args += ["-r", f"__node:={node.name}"]
    if node.namespace is not None:
        args += ["-r", f"__ns:={namespace or '/'}"]
    key = f"{namespace}/{node.name}" if node.name else "/**"
    for index, source in enumerate(node.parameters):
        if isinstance(source, dict):
            path = scratch / f"{node.name or node.executable}_parameters_{index}.yaml"
            path.write_text(yaml.safe_dump({key: {"ros__parameters": source}}))
            source = path
        args += ["--params-file", str(source)]
    for source, target in node.remappings:
        args += ["-r", f"{source}:={target}"]
    return args


@dataclass
class Running:
    node: Node
    command: list[str]
    process: subprocess.Popen
    restarts: int = 0
    restart_at: float | None = None


def supervise(commands: list[tuple[Node, list[str]]], environment: dict[str, str]) -> int:
    """Start every command, restart the respawning ones, stop all on Ctrl-C; the exit code."""
    env = {**os.environ, **environment}
    running = [Running(node, cmd, subprocess.Popen(cmd, env=env)) for node, cmd in commands]
    stopping_since: float | None = None
    codes: dict[int, int] = {}
    while len(codes) < len(running):
        now = time.monotonic()
        stopping_since = _stop_when_requested(running, stopping_since, now)
        for index, entry in enumerate(running):
            if index in codes:
                continue
            code = _exit_code(entry, stopping_since is None, now, env)
            if code is not None:
                codes[index] = code
        time.sleep(0.05)
    stopped = stopping_since is not None
    fine = all(code == 0 or (stopped and code in (-signal.SIGINT, 130)) for code in codes.values())
    return 0 if fine else 1


def _stop_when_requested(
    running: list[Running], stopping_since: float | None, now: float
) -> float | None:
    """When the stop (since `stopping_since`, None: not yet) is requested now, SIGINT to every
    command still running; STOP_WAIT_S after it, SIGTERM. Since when the run is stopping."""
    if stop_signals.requested() and stopping_since is None:
        stopping_since = now
        for entry in running:
            if entry.process.poll() is None:
                entry.process.send_signal(signal.SIGINT)
    if stopping_since is not None and now - stopping_since > STOP_WAIT_S:
        for entry in running:
            if entry.process.poll() is None:
                entry.process.terminate()
    return stopping_since


def _exit_code(entry: Running, may_respawn: bool, now: float, env: dict[str, str]) -> int | None:
    """The command's exit code once it has ended for good; None while it runs, or when it
    ended and respawns (with `may_respawn`): restarted `respawn_delay` s after it ended."""
    code = entry.process.poll()
    if code is None:
        return None
    if may_respawn and _respawns(entry):
        if entry.restart_at is None:
            entry.restart_at = now + entry.node.respawn_delay
        elif now >= entry.restart_at:
            entry.process = subprocess.Popen(entry.command, env=env)
            entry.restarts, entry.restart_at = entry.restarts + 1, None
        return None
    return code


def _respawns(entry: Running) -> bool:
    retries = entry.node.respawn_max_retries
    return entry.node.respawn and (retries < 0 or entry.restarts < retries)


def launch_file_path(install_dir: Path, package: str, file_name: str) -> Path:
    """install/<package>/share/<package>/launch/<file>, where `ros2 launch` looks."""
    path = install_dir / package / "share" / package / "launch" / file_name
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing: build the workspace first (make setup)")
    return path


def parse_launch_arguments(items: Sequence[str]) -> dict[str, str]:
    given = {}
    for item in items:
        name, separator, value = item.partition(":=")
        if not separator or not name:
            raise ValueError(f"launch arguments are name:=value, got '{item}'")
        given[name] = value
    return given


def main(argv: Sequence[str] | None = None) -> int:
    from tracker_ptz_sim.bringup.demo import install_space

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--print", action="store_true", help="print the commands and exit")
    parser.add_argument("package")
    parser.add_argument("launch_file")
    parser.add_argument("arguments", nargs="*", metavar="name:=value")
    args = parser.parse_args(argv)
    install_dir = install_space()
    try:
        path = launch_file_path(install_dir, args.package, args.launch_file)
        plan = resolve(load_description(path), parse_launch_arguments(args.arguments))
        scratch = Path(tempfile.mkdtemp(prefix="run_launch_"))
        commands = [
            (node, node_command(node, _executable(install_dir, node), scratch))
            for node in plan.nodes
        ]
    except (ValueError, FileNotFoundError) as error:
        print(f"[FATAL] run_launch: {error}", file=sys.stderr)
        return 2
    if args.print:
        for name, value in plan.environment.items():
            print(f"{name}={value}")
        for _, command in commands:
            print(" ".join(command))
        return 0
    try:
        return supervise(commands, plan.environment)  # stop handlers: by the entry point
    finally:
        shutil.rmtree(scratch, ignore_errors=True)  # the nodes have read their parameters


def _executable(install_dir: Path, node: Node) -> Path:
    return executable_path(install_dir, NodeSpec(node.package, node.executable, node.name or ""))
