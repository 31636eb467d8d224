"""The package READMEs' parameter tables are the nodes' parameters: every declared parameter is
documented with its default, and every documented one exists. The code's `ParamSpec`s are the one
description; this test keeps the README tables true to it."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

pytest.importorskip("rclpy")
pytestmark = pytest.mark.ros

SRC = Path(__file__).resolve().parents[2] / "src"


FUSION_OWN = (
    "explained_share",
    "motion_blobs",
    "motion_share",
    "still_score",
)


def node_parameters() -> dict[tuple[str, str], list]:
    """(README, heading before its table) -> the ParamSpecs of that node."""
    from tracker_detect.detector_node import NODE_PARAMETERS
    from tracker_detect.detectors import DETECTORS
    from tracker_filter import voxel_tracker_node
    from tracker_filter.tracker_node import parameter_specs
    from tracker_filter.trackers import TRACKERS
    from tracker_msgs_py.params import ParamSpec
    from tracker_ptz_sim.control import (
        axis_ptz_adapter_node,
        onvif_ptz_node,
        ptz_controller_node,
        ptz_state_bridge_node,
    )
    from tracker_ptz_sim.simulation import ptz_camera_node, video_source_node

    ptz = "tracker_ptz_sim/README.md"
    method = ParamSpec("method", "ssim", "")
    return {
        (ptz, "#### `video_source` parameters"): video_source_node.PARAMS,
        (ptz, "#### `ptz_camera` parameters"): ptz_camera_node.PARAMS,
        (ptz, "#### `ptz_controller` parameters"): ptz_controller_node.PARAMS,
        (ptz, "#### `ptz_state_bridge` parameters"): ptz_state_bridge_node.PARAMS,
        (ptz, "#### `axis_ptz_adapter` parameters"): axis_ptz_adapter_node.PARAMS,
        (ptz, "#### `onvif_ptz` parameters"): onvif_ptz_node.PARAMS,
        ("tracker_detect/README.md", "### Parameters"): [
            method,
            *DETECTORS.get("ssim").parameters,
            *NODE_PARAMETERS,
        ],
        ("tracker_detect/README.md", "### `ssim_background`"): list(
            DETECTORS.get("ssim_background").parameters
        ),
        ("tracker_detect/README.md", "### `camshift`"): list(DETECTORS.get("camshift").parameters),
        ("tracker_detect/README.md", "### `mog2`"): list(DETECTORS.get("mog2").parameters),
        ("tracker_detect/README.md", "### `person`"): list(DETECTORS.get("person").parameters),
        ("tracker_detect/README.md", "### `person_motion`"): [
            spec for spec in DETECTORS.get("person_motion").parameters if spec.name in FUSION_OWN
        ],
        ("tracker_filter/README.md", "### Parameters"): [
            ParamSpec("method", "gated_hungarian", ""),
            ParamSpec("preset", "", ""),
            *parameter_specs(TRACKERS.get("gated_hungarian"), "multi"),
        ],
        ("tracker_filter/README.md", "### `colour_particles`"): list(
            TRACKERS.get("colour_particles").parameters
        ),
        ("tracker_filter/README.md", "### `gm_phd`"): list(TRACKERS.get("gm_phd").parameters),
        ("tracker_filter/README.md", "### `byte`"): list(TRACKERS.get("byte").parameters),
        ("tracker_filter/README.md", "### `occupancy_particles`"): list(
            TRACKERS.get("occupancy_particles").parameters
        ),
        ("tracker_filter/README.md", "## Node `voxel_tracker`"): list(
            voxel_tracker_node.PARAMETERS
        ),
    }


def readme_rows(readme: str, heading: str) -> dict[str, str]:
    """Parameter name -> documented default, from the first table after `heading`."""
    lines = (SRC / readme).read_text().splitlines()
    start = lines.index(heading)
    rows: dict[str, str] = {}
    in_table = False
    for line in lines[start + 1 :]:
        if line.startswith("|"):
            in_table = True
            cells = [c.strip() for c in line.strip("|").split("|")]
            for name in re.findall(r"`([a-z_0-9]+)`", cells[0]):
                rows[name] = cells[1]
        elif in_table:
            break
    return rows


def parse(cell: str) -> object:
    text = cell.strip().strip("`").strip()
    if text in ("''", '""'):
        return ""
    if len(text) > 1 and text[0] == text[-1] and text[0] in "'\"":
        return text[1:-1]
    if text in ("true", "false"):
        return text == "true"
    if text.startswith("[") and text.endswith("]"):
        return [parse(item) for item in text[1:-1].split(",") if item.strip()]
    try:
        return float(text)
    except ValueError:
        return text


def same(documented: object, default: object) -> bool:
    if isinstance(default, bool) or isinstance(documented, bool):
        return documented == default
    if isinstance(default, int | float) and isinstance(documented, float):
        return math.isclose(documented, default, rel_tol=1e-3, abs_tol=1e-9)
    if isinstance(default, list) and isinstance(documented, list):
        return len(default) == len(documented) and all(
            same(d, v) for d, v in zip(documented, default, strict=True)
        )
    return documented == default


LONG_LIST = 8  # matrices (model_*): the README describes them instead of listing every number


@pytest.mark.parametrize("table", list(node_parameters()), ids=lambda t: f"{t[0]} {t[1]}")
def test_readme_table_matches_the_declared_parameters(table):
    specs = node_parameters()[table]
    rows = readme_rows(*table)
    declared = {spec.name: spec.default for spec in specs}
    problems = [f"undocumented: {name}" for name in declared if name not in rows]
    problems += [f"documented but not declared: {name}" for name in rows if name not in declared]
    for name, default in declared.items():
        if name not in rows or (isinstance(default, list) and len(default) > LONG_LIST):
            continue
        if not same(parse(rows[name]), default):
            problems.append(f"{name}: README says {rows[name]!r}, the code {default!r}")
    assert problems == [], "\n".join(problems)
