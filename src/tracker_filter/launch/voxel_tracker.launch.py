"""The 3-D voxel tracker (seed 002): occupancy PointCloud2 in, 3-D tracks out.

    ros2 launch tracker_filter voxel_tracker.launch.py occupancy:=/reconstruction/voxels

Arguments: `occupancy` (the topic your reconstruction publishes occupied voxel centres on),
`tracks` (where the tracks go), `params_file` (default: config/voxel_tracker.yaml, the thesis's
room; copy and edit it for yours), `use_sim_time` (true when replaying a bag with --clock).
"""

from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue


def generate_launch_description() -> LaunchDescription:
    share = Path(get_package_share_directory("tracker_filter"))
    return LaunchDescription(
        [
            DeclareLaunchArgument("occupancy", default_value="occupancy"),
            DeclareLaunchArgument("tracks", default_value="tracks"),
            DeclareLaunchArgument(
                "params_file", default_value=str(share / "config" / "voxel_tracker.yaml")
            ),
            DeclareLaunchArgument("use_sim_time", default_value="false"),
            Node(
                package="tracker_filter",
                executable="voxel_tracker",
                name="voxel_tracker",
                output="screen",
                parameters=[
                    LaunchConfiguration("params_file"),
                    {
                        "use_sim_time": ParameterValue(
                            LaunchConfiguration("use_sim_time"), value_type=bool
                        )
                    },
                ],
                remappings=[
                    ("occupancy", LaunchConfiguration("occupancy")),
                    ("tracks", LaunchConfiguration("tracks")),
                ],
            ),
        ]
    )
