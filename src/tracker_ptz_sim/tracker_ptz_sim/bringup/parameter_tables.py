"""The package READMEs' parameter tables, generated from the parameters' one declaration.

Each table sits between ``<!-- parameters: KEY -->`` and ``<!-- /parameters -->`` in a package
README; `TABLES` says which parameters KEY stands for (a method's config fields, a node's
`ParamSpec`s). ``parameter_tables`` rewrites every table; ``parameter_tables --check`` lists the
stale ones and exits 1 (the test suite runs it).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from tracker_msgs_py.params import ParamSpec, markdown_table

README_PACKAGES = ("tracker_detect", "tracker_filter", "tracker_ptz_sim")
BLOCK = re.compile(
    r"(<!-- parameters: (?P<key>[a-z_0-9/]+) -->\n)(?P<table>.*?)(<!-- /parameters -->)", re.S
)


def _detector(name: str) -> Callable[[], Sequence[ParamSpec]]:
    def specs() -> Sequence[ParamSpec]:
        from tracker_detect.detectors import DETECTORS

        return DETECTORS.get(name).parameters

    return specs


def _tracker(name: str) -> Callable[[], Sequence[ParamSpec]]:
    def specs() -> Sequence[ParamSpec]:
        from tracker_filter.trackers import TRACKERS

        return TRACKERS.get(name).parameters

    return specs


def _detector_node() -> Sequence[ParamSpec]:
    from tracker_detect.detector_node import NODE_PARAMETERS
    from tracker_detect.detectors import DETECTORS

    first = DETECTORS.get(DETECTORS.names()[0])
    return [DETECTORS.method_spec(), *first.parameters, *NODE_PARAMETERS]


def _fusion_own() -> Sequence[ParamSpec]:
    """The person_motion detector's own parameters, and those of ssim_background and person it
    gives other defaults."""
    from tracker_detect.detectors import DETECTORS

    parts = {
        s.name: s.default
        for name in ("ssim_background", "person")
        for s in DETECTORS.get(name).parameters
    }
    return [
        s
        for s in DETECTORS.get("person_motion").parameters
        if s.name not in parts or parts[s.name] != s.default
    ]


def _tracker_node() -> Sequence[ParamSpec]:
    from tracker_filter.tracker_node import PRESET_PARAMETER, parameter_specs
    from tracker_filter.trackers import TRACKERS

    multi = parameter_specs(TRACKERS.get("gated_hungarian"), "multi")
    return [TRACKERS.method_spec(), PRESET_PARAMETER, *multi]


def _node(module: str, attribute: str = "PARAMS") -> Callable[[], Sequence[ParamSpec]]:
    def specs() -> Sequence[ParamSpec]:
        from importlib import import_module

        found: Sequence[ParamSpec] = getattr(import_module(module), attribute)
        return found

    return specs


#: table key -> the parameters it documents, in the order the node declares them
TABLES: dict[str, Callable[[], Sequence[ParamSpec]]] = {
    "detector": _detector_node,
    "detector/ssim_background": _detector("ssim_background"),
    "detector/camshift": _detector("camshift"),
    "detector/mog2": _detector("mog2"),
    "detector/person": _detector("person"),
    "detector/person_motion": _fusion_own,
    "tracker": _tracker_node,
    "tracker/colour_particles": _tracker("colour_particles"),
    "tracker/gm_phd": _tracker("gm_phd"),
    "tracker/byte": _tracker("byte"),
    "tracker/occupancy_particles": _tracker("occupancy_particles"),
    "voxel_tracker": _node("tracker_filter.voxel_tracker_node", "PARAMETERS"),
    "video_source": _node("tracker_ptz_sim.simulation.video_source_node"),
    "ptz_camera": _node("tracker_ptz_sim.simulation.ptz_camera_node"),
    "ptz_controller": _node("tracker_ptz_sim.control.ptz_controller_node"),
    "ptz_state_bridge": _node("tracker_ptz_sim.control.ptz_state_bridge_node"),
    "axis_ptz_adapter": _node("tracker_ptz_sim.control.axis_ptz_adapter_node"),
    "onvif_ptz": _node("tracker_ptz_sim.control.onvif_ptz_node"),
}


def _gated_hungarian_presets() -> dict[str, dict[str, Any]]:
    """The tracker table's other presets (its defaults are `multi`'s)."""
    from tracker_filter.trackers import TRACKERS

    presets = TRACKERS.get("gated_hungarian").presets
    return {name: dict(values) for name, values in presets.items() if name != "multi"}


#: table key -> the presets whose values the table shows beside the defaults
PRESET_COLUMNS: dict[str, Callable[[], dict[str, dict[str, Any]]]] = {
    "tracker": _gated_hungarian_presets,
}


def table(key: str) -> str:
    """The markdown table of the parameters `key` stands for."""
    presets = PRESET_COLUMNS[key]() if key in PRESET_COLUMNS else None
    return markdown_table(TABLES[key](), presets)


def regenerate(text: str) -> tuple[str, list[str]]:
    """`text` with every parameters block rewritten, and the keys of the blocks that changed."""
    changed: list[str] = []

    def rewrite(match: re.Match[str]) -> str:
        key = match["key"]
        if key not in TABLES:
            raise ValueError(f"unknown parameters table '{key}' (known: {', '.join(TABLES)})")
        fresh = table(key) + "\n"
        if fresh != match["table"]:
            changed.append(key)
        return match[1] + fresh + match[4]

    return BLOCK.sub(rewrite, text), changed


def readmes(src: Path) -> list[Path]:
    return [src / package / "README.md" for package in README_PACKAGES]


def documented_keys(src: Path) -> list[str]:
    """The table keys the READMEs hold, in order (a key twice is a mistake the test reports)."""
    return [m["key"] for path in readmes(src) for m in BLOCK.finditer(path.read_text())]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--src", type=Path, default=Path("src"), help="the workspace's src/")
    parser.add_argument("--check", action="store_true", help="only list stale tables (exit 1)")
    args = parser.parse_args(argv)
    stale = []
    for path in readmes(args.src):
        text = path.read_text()
        fresh, changed = regenerate(text)
        stale += [f"{path}: {key}" for key in changed]
        if changed and not args.check:
            path.write_text(fresh)
    for line in stale:
        print(("stale " if args.check else "rewrote ") + line)
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
