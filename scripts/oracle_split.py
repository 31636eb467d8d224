"""A diagnostic: how far would the tracker get if the detector told overlapping people apart?

    python scripts/oracle_split.py --scenes groups walkers --configs suite --seeds 12 \
        --out out/oracle_split

Runs `benchmark` in process with its own arguments (`--graph` is refused) and one change before
the tracker: a detection box that holds two or more people -- each with at least half of their
visible box (clipped to the camera view) inside it -- and matches none of them at IoU 0.5 is
replaced by those people's visible boxes from the ground truth. Every other detection is passed
on as detected, so the tracker, the target selection and the camera run as shipped. The gap
between its table and `benchmark`'s is what merged blobs cost (README, issue 11's status).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from tracker_filter.observation import Detections
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.bringup import benchmark, pipeline
from tracker_ptz_sim.evaluation import metrics


class GroundTruthSplit:
    """Replaces merged detections with the visible boxes of the people they hold."""

    def __init__(self) -> None:
        self.truth: metrics.Boxes = {}
        self.frame = 0  # MOTChallenge frame number of the step being tracked
        self.window = Rect(0.0, 0.0, 0.0, 0.0)
        self.replaced = 0  # detections replaced, over the whole run

    def start_scene(self, scene_dir: Path) -> None:
        self.truth = metrics.load_mot(scene_dir / "gt" / "gt.txt")
        self.frame = 0

    def next_step(self, window: Rect) -> None:
        self.frame += 1
        self.window = window

    def people_in_view(self) -> list[Rect]:
        people = []
        for box in self.truth.get(self.frame, {}).values():
            clipped = box.intersection(self.window)
            if clipped is not None and clipped.width > 2 and clipped.height > 2:
                people.append(clipped)
        return people

    def split(self, found: Detections) -> Detections:
        people = self.people_in_view()
        if not len(found) or not people:
            return found
        positions, areas, boxes, scores = [], [], [], []
        replaced_before = self.replaced
        for i in range(len(found)):
            box = Rect(*(float(v) for v in found.bboxes[i]))
            held = [p for p in people if box.intersection_area(p) >= 0.5 * p.area]
            if len(held) >= 2 and max(box.iou(p) for p in held) < 0.5:
                self.replaced += 1
                for person in held:
                    positions.append(person.center)
                    areas.append(person.area)
                    boxes.append((person.x, person.y, person.width, person.height))
                    scores.append(float(found.scores[i]))
            else:
                positions.append(tuple(found.positions[i]))
                areas.append(float(found.areas[i]))
                boxes.append(tuple(found.bboxes[i]))
                scores.append(float(found.scores[i]))
        if self.replaced == replaced_before:
            return found
        return Detections(
            np.array(positions, dtype=float),
            np.array(areas, dtype=float),
            np.array(boxes, dtype=float),
            np.array(scores, dtype=float),
        )


def install(oracle: GroundTruthSplit) -> None:
    """Wrap the benchmark's run of one scene, the tracking stage and its detection conversion."""
    run_one, track, convert = (
        benchmark.benchmark_one,
        pipeline.TrackingStage.step,
        pipeline.detections_of,
    )

    def benchmark_one(scene_name: str, scene_dir: Path, *args: Any, **kwargs: Any) -> Any:
        oracle.start_scene(Path(scene_dir))
        return run_one(scene_name, scene_dir, *args, **kwargs)

    def step(
        self: pipeline.TrackingStage, stamp_ns: int, view: Any, detection: Any, window: Rect
    ) -> Any:
        oracle.next_step(window)
        return track(self, stamp_ns, view, detection, window)

    benchmark.benchmark_one = benchmark_one
    pipeline.TrackingStage.step = step  # type: ignore[method-assign]
    pipeline.detections_of = lambda detection: oracle.split(convert(detection))


def main(argv: list[str]) -> int:
    if "--graph" in argv:
        raise SystemExit("oracle_split runs in process only (the split is made inside the loop)")
    oracle = GroundTruthSplit()
    install(oracle)
    code = benchmark.main(argv)
    print(f"oracle_split: {oracle.replaced} detections replaced by the people they held")
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
