"""The code's layering: dependencies point one way, and the functional core imports no rclpy.

Reads the imports of every module (module level and inside functions) without importing them.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"
PTZ = SRC / "tracker_ptz_sim" / "tracker_ptz_sim"

# Which tracker_ptz_sim subpackages each one may import.
ALLOWED = {
    "simulation": {"simulation"},
    "control": {"control"},
    "evaluation": {"evaluation"},
    "annotation": {"annotation", "simulation"},
    "bringup": {"simulation", "control", "evaluation", "annotation", "bringup"},
}

# Modules that are ROS shells (nodes, process runners), allowed to import rclpy.
ROS_SHELLS = {
    "node_main",
    "params",
    "entry_points",
    "tracker_node",
    "detector_node",
    "video_source_node",
    "ptz_camera_node",
    "ptz_controller_node",
    "ptz_state_bridge_node",
    "ptz_tf_node",
    "axis_ptz_adapter_node",
    "onvif_ptz_node",
    "live_view_node",
    "graph_host",
    "demo",
}


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def python_modules() -> list[Path]:
    return sorted(
        p
        for p in SRC.glob("*/*/**/*.py")
        if p.parent.name != "launch" and p.name != "setup.py" and "test" not in p.parts
    )


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_tracker_ptz_sim_layers_depend_one_way(layer):
    for path in sorted((PTZ / layer).glob("*.py")):
        for name in imported_modules(path):
            parts = name.split(".")
            if parts[0] == "tracker_ptz_sim" and len(parts) > 1 and parts[1] in ALLOWED:
                assert parts[1] in ALLOWED[layer], f"{path.relative_to(SRC)} imports {name}"


def test_every_tracker_ptz_sim_module_is_in_a_layer():
    loose = [p.name for p in PTZ.glob("*.py") if p.name not in ("__init__.py", "entry_points.py")]
    assert loose == []


def test_the_functional_core_imports_no_rclpy():
    offenders = []
    for path in python_modules():
        if path.stem in ROS_SHELLS:
            continue
        uses_rclpy = any(n.split(".")[0] == "rclpy" for n in imported_modules(path))
        if uses_rclpy and path.name != "codec.py":  # codec: QoS profiles, inside image_qos()
            offenders.append(str(path.relative_to(SRC)))
    assert offenders == []


def test_main_guard_comes_last() -> None:
    """`python -m package.module` runs the module's `if __name__ == "__main__"` block as it is
    reached: a function defined below it is not defined yet (run_demo's summary line once
    failed that way). Only the console-script entry point imported the whole module first."""
    late = []
    for path in python_modules() + sorted((SRC.parent / "scripts").glob("*.py")):
        body = ast.parse(path.read_text(), str(path)).body
        guards = [
            i
            for i, node in enumerate(body)
            if isinstance(node, ast.If) and "__main__" in ast.unparse(node.test)
        ]
        if guards and guards[-1] != len(body) - 1:
            late.append(f"{path.relative_to(SRC.parent)}: line {body[guards[-1]].lineno}")
    assert not late, f"statements after the __main__ guard: {late}"
