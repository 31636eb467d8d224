"""ros2 launch tracker_ptz_sim surveillance.launch.py video:=/path/to/video.mp4
    [controller_mode:=servo] [respawn:=true]

The whole surveillance graph, built from the same config/graph.yaml + config/surveillance.yaml the
demo runner (make demo) uses, so both run exactly the same nodes with the same parameters.
With respawn:=true a processing node that exits is started again (after 1 s, at most 5 times).
video_source is not respawned: it exits 0 at the end of the stream, which launch cannot tell from
a crash (`run_demo --respawn` restarts it where it left off; a source restarted from its first
frame is taken as a new replay epoch by every node).
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from tracker_ptz_sim.bringup.graph import load_graph


def generate_launch_description():
    graph = load_graph()
    arguments = [
        DeclareLaunchArgument("video", description="video file, image folder or rosbag2 to replay"),
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
            parameters=[str(graph.params_file), overrides.get(node.name, {})],
            remappings=list(node.remappings.items()),
            output="screen",
            **(respawn if node.name != "video_source" else {}),
        )
        for node in graph.nodes
    ]
    # Large images need a shared-memory segment bigger than Fast DDS's default (see the profile).
    profile = graph.params_file.parent / "fastdds_shm.xml"
    environment = []
    if "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ and profile.exists():
        environment.append(SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile)))
    return LaunchDescription(arguments + environment + nodes)
