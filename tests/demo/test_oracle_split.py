"""scripts/oracle_split.py: merged detections replaced by the people they hold, nothing else."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from tracker_filter.observation import Detections
from tracker_msgs_py.geometry import Rect

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "oracle_split.py"


@pytest.fixture(scope="module")
def oracle_split():
    spec = importlib.util.spec_from_file_location("oracle_split", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _detections(boxes):
    boxes = np.asarray(boxes, dtype=float)
    return Detections(
        boxes[:, :2] + boxes[:, 2:] / 2,
        boxes[:, 2] * boxes[:, 3],
        boxes,
        np.ones(len(boxes)),
    )


def test_a_blob_over_two_people_becomes_their_boxes_and_a_single_person_stays(oracle_split):
    oracle = oracle_split.GroundTruthSplit()
    oracle.truth = {
        1: {
            1: Rect(100, 100, 30, 90),  # a pair, side by side
            2: Rect(125, 105, 30, 85),
            3: Rect(300, 100, 30, 90),  # alone
            4: Rect(700, 100, 30, 90),  # outside the view
        }
    }
    oracle.next_step(Rect(0, 0, 500, 400))
    found = _detections([[98, 99, 60, 93], [301, 98, 31, 94], [10, 10, 8, 8]])
    split = oracle.split(found)
    assert oracle.replaced == 1
    np.testing.assert_allclose(
        split.bboxes, [[100, 100, 30, 90], [125, 105, 30, 85], [301, 98, 31, 94], [10, 10, 8, 8]]
    )
    np.testing.assert_allclose(split.positions[:2], [[115, 145], [140, 147.5]])


def test_a_blob_that_matches_one_of_the_people_is_left_alone(oracle_split):
    """One person nearly hidden behind another: the blob is the front one's box (IoU >= 0.5)."""
    oracle = oracle_split.GroundTruthSplit()
    oracle.truth = {1: {1: Rect(100, 100, 30, 90), 2: Rect(105, 110, 20, 70)}}
    oracle.next_step(Rect(0, 0, 500, 400))
    found = _detections([[100, 100, 31, 91]])
    assert oracle.split(found) is found and oracle.replaced == 0


def test_the_script_refuses_graph_runs(oracle_split):
    with pytest.raises(SystemExit, match="in process only"):
        oracle_split.main(["--graph"])
    assert sys.modules.get("oracle_split") is None  # loaded from its file, not installed
