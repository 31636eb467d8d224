"""Check surveillance.launch.py with the real `launch` and `launch_ros`: two cameras side by side,
one under `namespace:=cam1`, one included under a PushRosNamespace, both with
`controller_mode:=direct`; then ask the running nodes for their parameters over their parameter
services and list the clock topics.

    source scripts/env.sh   # or a sourced ROS 2 Jazzy install, which has launch and launch_ros
    python scripts/check_launch.py [VIDEO]

`launch` and `launch_ros` are not on PyPI; on a wheels-only machine put their sources (the jazzy
branches of ros2/launch and ros2/launch_ros) and their PyPI dependencies (osrf_pycommon, lark) on
PYTHONPATH. composition_interfaces and lifecycle_msgs (not on PyPI either; plain Nodes never use
them) are stood in for when missing. Expected output (2026-11-25, Jazzy branches):

    /cam1/ptz_controller {'mode': 'direct', 'zoom_control': True, 'use_sim_time': True}
    /cam2/ptz_controller {'mode': 'direct', 'zoom_control': True, 'use_sim_time': True}
    /cam1/tracker {'selection_policy': 'farthest_travelled', 'use_sim_time': True}
    /cam2/video_source {'path': '...', 'lockstep': True, 'publish_clock': True}
    clock topics: ['/cam1/clock', '/cam2/clock']
"""

from __future__ import annotations

import importlib
import os
import sys
import threading
import time
import types
from pathlib import Path

SETTLE_S = 15.0  # let both graphs start before asking them


def stand_in_for_missing_interfaces() -> None:
    class Anything(type):
        def __getattr__(cls, attr: str) -> int:
            return 0

    for package in ("composition_interfaces", "lifecycle_msgs"):
        try:
            importlib.import_module(f"{package}.msg")
            continue
        except ImportError:
            pass
        top = types.ModuleType(package)
        sys.modules[package] = top
        for sub in ("msg", "srv"):
            module = types.ModuleType(f"{package}.{sub}")
            module.__getattr__ = lambda attr: Anything(attr, (), {})  # type: ignore[method-assign]
            sys.modules[f"{package}.{sub}"] = module
            setattr(top, sub, module)


def main() -> int:
    stand_in_for_missing_interfaces()
    import launch
    import rclpy
    from launch.actions import GroupAction, IncludeLaunchDescription
    from launch.launch_description_sources import PythonLaunchDescriptionSource
    from launch_ros.actions import PushRosNamespace
    from rcl_interfaces.msg import ParameterType
    from rcl_interfaces.srv import GetParameters

    from tracker_msgs_py.package_files import package_data

    launch_file = package_data("tracker_ptz_sim", "launch") / "surveillance.launch.py"
    default_video = Path.home() / ".cache/tracker_suite/vtest.avi"
    video = sys.argv[1] if len(sys.argv) > 1 else str(default_video)
    cameras = [({"namespace": "cam1"}, None), ({}, "cam2")]
    entities = []
    for arguments, pushed in cameras:
        include = IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(launch_file)),
            launch_arguments={"video": video, "controller_mode": "direct", **arguments}.items(),
        )
        entities.append(GroupAction([PushRosNamespace(pushed), include] if pushed else [include]))
    service = launch.LaunchService()
    service.include_launch_description(launch.LaunchDescription(entities))
    queries = [
        ("/cam1/ptz_controller", ["mode", "zoom_control", "use_sim_time"]),
        ("/cam2/ptz_controller", ["mode", "zoom_control", "use_sim_time"]),
        ("/cam1/tracker", ["selection_policy", "use_sim_time"]),
        ("/cam2/video_source", ["path", "lockstep", "publish_clock"]),
    ]

    def ask() -> None:
        time.sleep(SETTLE_S)
        rclpy.init()
        node = rclpy.create_node("launch_check")
        for name, parameters in queries:
            client = node.create_client(GetParameters, f"{name}/get_parameters")
            if not client.wait_for_service(timeout_sec=10.0):
                print(name, "did not start", flush=True)
                continue
            future = client.call_async(GetParameters.Request(names=parameters))
            rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
            values = {
                p: v.string_value if v.type == ParameterType.PARAMETER_STRING else v.bool_value
                for p, v in zip(parameters, future.result().values, strict=True)
            }
            print(name, values, flush=True)
        topics = node.get_topic_names_and_types()
        print("clock topics:", sorted(t for t, _ in topics if t.endswith("clock")), flush=True)
        node.destroy_node()
        rclpy.shutdown()
        service.shutdown()

    threading.Thread(target=ask, daemon=True).start()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return service.run()


if __name__ == "__main__":
    raise SystemExit(main())
