"""ros2 launch tracker_ptz_sim surveillance.launch.py video:=/path/to/video.mp4 [controller_mode:=servo]

The whole surveillance graph, built from the same config/graph.yaml + config/surveillance.yaml the
demo runner (make demo) uses, so both run exactly the same nodes with the same parameters.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from tracker_ptz_sim.graph import load_graph


def generate_launch_description():
    graph = load_graph()
    arguments = [
        DeclareLaunchArgument("video", description="video file, image folder or rosbag2 to replay"),
        DeclareLaunchArgument(
            "controller_mode",
            default_value="servo",
            description="ptz_controller mode: direct or servo",
        ),
    ]
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
        )
        for node in graph.nodes
    ]
    # Large images need a shared-memory segment bigger than Fast DDS's default (see the profile).
    profile = graph.params_file.parent / "fastdds_shm.xml"
    environment = []
    if "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ and profile.exists():
        environment.append(SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile)))
    return LaunchDescription(arguments + environment + nodes)
