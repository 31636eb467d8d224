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


def module_name(path: Path) -> str:
    """`src/<package>/<package>/a/b.py` -> `<package>.a.b`."""
    parts = path.relative_to(SRC).with_suffix("").parts[1:]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """Module -> the suite's modules it imports (module level or inside a function)."""
    modules = {module_name(p): p for p in python_modules()}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        graph[name] = {n for n in imported_modules(path) if n in modules and n != name}
    return graph


def reachable(graph: dict[str, set[str]], start: str) -> set[str]:
    """Every module `start` imports, directly or through others."""
    seen: set[str] = set()
    todo = list(graph[start])
    while todo:
        node = todo.pop()
        if node not in seen:
            seen.add(node)
            todo.extend(graph[node])
    return seen


def modules_in_cycles(graph: dict[str, set[str]]) -> list[str]:
    """The modules that import themselves through others."""
    return sorted(node for node in graph if node in reachable(graph, node))


def test_no_import_cycles():
    """Not even through an import inside a function: a cycle there is still one."""
    assert modules_in_cycles(import_graph()) == []


# Each plug-in family is a subpackage; one family never imports another's modules (the shared
# pieces beside them -- tracking, management, filters, selection, observation, blobs, ... -- are
# for every family).
TRACKER_FAMILIES = {"gated_hungarian", "particles", "gm_phd", "occupancy", "byte"}
DETECTOR_FAMILIES = {"motion", "background", "camshift", "mog2", "person"}
#: families made of others: ssim_background tells changing pixels from still ones with motion's
#: frame comparison; person_motion (person/fusion) is the background's motion and the person model
COMPOSITES = {"background": {"motion"}, "person": {"background"}}


def family(module: str, package: str, families: set[str]) -> str | None:
    parts = module.split(".")
    return parts[1] if parts[0] == package and len(parts) > 2 and parts[1] in families else None


@pytest.mark.parametrize(
    ("package", "families"),
    [("tracker_filter", TRACKER_FAMILIES), ("tracker_detect", DETECTOR_FAMILIES)],
)
def test_every_method_family_is_a_subpackage(package, families):
    root = SRC / package / package
    assert {p.parent.name for p in root.glob("*/__init__.py")} == families


@pytest.mark.parametrize(
    ("package", "families"),
    [("tracker_filter", TRACKER_FAMILIES), ("tracker_detect", DETECTOR_FAMILIES)],
)
def test_no_plug_in_imports_another_family(package, families):
    crossings = []
    for module, imported in import_graph().items():
        own = family(module, package, families)
        if own is None:
            continue
        allowed = {own} | COMPOSITES.get(own, set())
        for other in sorted(imported):
            theirs = family(other, package, families)
            if theirs is not None and theirs not in allowed:
                crossings.append(f"{module} -> {other}")
    assert crossings == []
