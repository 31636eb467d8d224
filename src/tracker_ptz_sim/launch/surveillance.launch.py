"""ros2 launch tracker_ptz_sim surveillance.launch.py video:=/path/to/video.mp4
    [graph:=surveillance|colour|standard] [controller_mode:=servo] [respawn:=true]

The whole graph, built from the same config/*graph.yaml and parameter files the demo runner
(make demo) uses, so both run exactly the same nodes with the same parameters. graph:=colour runs
the colour-following graph (motion hands its target over to CamShift; seed 001); graph:=standard
the surveillance graph behind a simulated camera that speaks only sensor_msgs, as real drivers do.
With respawn:=true a processing node that exits is started again (after 1 s, at most 5 times).
video_source is not respawned: it exits 0 at the end of the stream, which launch cannot tell from
a crash (`run_demo --respawn` restarts it where it left off; a source restarted from its first
frame is taken as a new replay epoch by every node).
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from tracker_ptz_sim.bringup.graph import GRAPHS, load_graph


def generate_launch_description():
    arguments = [
        DeclareLaunchArgument("video", description="video file, image folder or rosbag2 to replay"),
        DeclareLaunchArgument(
            "graph",
            default_value="surveillance",
            choices=list(GRAPHS),
            description="which graph: surveillance (motion), colour (motion hands over to "
            "CamShift) or standard (surveillance behind sensor_msgs-only drivers)",
        ),
        DeclareLaunchArgument(
            "controller_mode",
            default_value="servo",
            description="ptz_controller mode: direct or servo",
        ),
        DeclareLaunchArgument(
            "respawn",
            default_value="false",
            description="restart a processing node that exits (not video_source)",
        ),
    ]
    return LaunchDescription(arguments + [OpaqueFunction(function=graph_actions)])


def graph_actions(context):
    """The chosen graph's nodes (and the shared-memory profile), once `graph` is known."""
    graph = load_graph(LaunchConfiguration("graph").perform(context))
    respawn = {
        "respawn": LaunchConfiguration("respawn"),
        "respawn_delay": 1.0,
        "respawn_max_retries": 5,
    }
    overrides = {
        "video_source": {"path": LaunchConfiguration("video")},
        "ptz_controller": {"mode": LaunchConfiguration("controller_mode")},
    }
    nodes = [
        Node(
            package=node.package,
            executable=node.executable,
            name=node.name,
            parameters=[*map(str, graph.params_files), overrides.get(node.name, {})],
            remappings=list(node.remappings.items()),
            output="screen",
            **(respawn if node.name != "video_source" else {}),
        )
        for node in graph.nodes
    ]
    # Large images need a shared-memory segment bigger than Fast DDS's default (see the profile).
    profile = graph.config_dir / "fastdds_shm.xml"
    environment = []
    if "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ and profile.exists():
        environment.append(SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile)))
    return environment + nodes
