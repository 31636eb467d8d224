"""Every package's package.xml declares, as valid rosdep keys, exactly the dependencies its code
imports: `rosdep install --from-paths src` then installs what the nodes need and nothing unused."""

from __future__ import annotations

import ast
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("tracker_msgs", "tracker_detect", "tracker_filter", "tracker_ptz_sim")
WORKSPACE_MODULES = {"tracker_msgs_py": "tracker_msgs", **{p: p for p in PACKAGES}}
# Python modules -> rosdep keys (a ROS package's module is its own key).
PYTHON_KEYS = {
    "cv2": "python3-opencv",
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "numba": "python3-numba",
    "filterpy": "python3-filterpy-pip",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "rosbags": "python3-rosbags-pip",
    "motmetrics": "python3-motmetrics-pip",
    "trackeval": "python3-trackeval-pip",
    "foxglove": "python3-foxglove-sdk-pip",
    "onnxruntime": "python3-onnxruntime-pip",
    "onvif": "python3-onvif-zeep-async-pip",
}
# Keys in rosdistro's rosdep/python.yaml, looked up by hand in ros/rosdistro on 2026-11-25
# (python3-filterpy and python3-rosbags are not keys there; their -pip forms are).
ROSDISTRO_KEYS = {
    "python3-opencv",
    "python3-numpy",
    "python3-scipy",
    "python3-numba",
    "python3-filterpy-pip",
    "python3-yaml",
    "python3-matplotlib",
    "python3-rosbags-pip",
    "python3-onnxruntime-pip",  # ros/rosdistro#32307
    "python3-pytest",
}
# ROS 2 Jazzy packages (rosdep resolves them from the distribution).
ROS_PACKAGES = {
    "rclpy",
    "launch",
    "launch_ros",
    "ament_index_python",
    "builtin_interfaces",
    "rcl_interfaces",
    "rosgraph_msgs",
    "std_msgs",
    "sensor_msgs",
    "diagnostic_msgs",
    "vision_msgs",  # ros-jazzy-vision-msgs (src/interfaces stands in on the wheels)
    "tf2_msgs",
    "ptz_action_server_msgs",  # Clearpath's, released for Jazzy (its Ptz.msg stands in here)
    "geometry_msgs",
    "robot_state_publisher",  # the launch file's TF publisher where installed
    "rosidl_default_runtime",
    "rosidl_default_generators",
    "ament_cmake",
    "ament_cmake_python",
}


def own_keys() -> set[str]:
    return set(yaml.safe_load((ROOT / "rosdep/tracker_suite.yaml").read_text()))


def imported_modules(package: str) -> set[str]:
    names: set[str] = set()
    for path in (ROOT / "src" / package).rglob("*.py"):
        if path.name == "setup.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names}


def needed_keys(package: str) -> set[str]:
    keys = set()
    for module in imported_modules(package):
        if module in WORKSPACE_MODULES:
            if WORKSPACE_MODULES[module] != package:
                keys.add(WORKSPACE_MODULES[module])
        else:
            keys.add(PYTHON_KEYS.get(module, module))
    return keys


def declared(package: str, *tags: str) -> set[str]:
    root = ElementTree.parse(ROOT / "src" / package / "package.xml").getroot()
    return {element.text.strip() for tag in tags for element in root.iter(tag)}


@pytest.mark.parametrize("package", PACKAGES)
def test_every_import_is_a_declared_run_dependency(package):
    run = declared(package, "exec_depend", "depend")
    assert needed_keys(package) - run == set()


@pytest.mark.parametrize("package", PACKAGES)
def test_no_python_library_is_declared_without_being_imported(package):
    libraries = {k for k in declared(package, "exec_depend", "depend") if k.startswith("python3-")}
    assert libraries - needed_keys(package) == set()


@pytest.mark.parametrize("package", PACKAGES)
def test_every_declared_key_resolves(package):
    tags = ("exec_depend", "depend", "build_depend", "buildtool_depend", "test_depend")
    valid = ROSDISTRO_KEYS | own_keys() | ROS_PACKAGES | set(PACKAGES)
    assert declared(package, *tags) - valid == set()


def test_the_own_rosdep_keys_install_from_pip_and_are_not_in_rosdistro():
    for key, rule in yaml.safe_load((ROOT / "rosdep/tracker_suite.yaml").read_text()).items():
        assert key.endswith("-pip") and key not in ROSDISTRO_KEYS
        assert rule["*"]["pip"]["packages"]
