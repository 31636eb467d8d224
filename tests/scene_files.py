"""A generated scene written with `write_scene` and loaded back, checked to be the same scene."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from tracker_ptz_sim.simulation.scene_files import ScenePaths, load_scene, write_scene


def assert_reloads_exactly(scene: Any, root: Path, generator: str) -> ScenePaths:
    """Writes `scene` under `root`, checks scene.json names `generator` and that the loaded
    scene has the same config (of the same type), uint16 labels, frames and boxes; its paths."""
    paths = write_scene(scene, root)
    assert json.loads(paths.meta.read_text())["generator"] == generator
    loaded = load_scene(paths.root)
    assert loaded.config == scene.config and type(loaded.config) is type(scene.config)
    assert loaded.labels.dtype == np.uint16 and np.array_equal(loaded.labels, scene.labels)
    assert np.array_equal(loaded.frames, scene.frames)
    assert loaded.boxes == scene.boxes
    return paths
