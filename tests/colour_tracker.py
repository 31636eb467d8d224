"""A small test-only tracker that needs the colour image: it follows the one saturated-red region
of the camera view and ignores the detections. It exists to prove the plug-in shape: registered
in `trackers.TRACKERS`, it runs through the real tracker node without any change to node code.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from tracker_filter.layout import StateLayout
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.params import ParamSpec
from tracker_msgs_py.registry import Method

LAYOUT = StateLayout.from_names("x y w h")  # a box, no velocity


def red_box(image: np.ndarray, min_pixels: int) -> tuple[float, float, float, float] | None:
    """Box x, y, w, h (camera px) of the pixels with R > 150 and G, B < 80, or None."""
    red = (image[:, :, 2] > 150) & (image[:, :, 1] < 80) & (image[:, :, 0] < 80)
    rows, cols = np.nonzero(red)
    if rows.size < min_pixels:
        return None
    x0, x1, y0, y1 = cols.min(), cols.max() + 1, rows.min(), rows.max() + 1
    return float(x0), float(y0), float(x1 - x0), float(y1 - y0)


class RedBlobTracker:
    """At most one track: the red region, in scene pixels through the camera window."""

    needs = frozenset({Need.IMAGE, Need.WINDOW})
    layout = LAYOUT

    def __init__(self, min_pixels: int = 4, max_misses: int = 2, first_id: int = 1) -> None:
        self.min_pixels, self.max_misses = min_pixels, max_misses
        self.book = TrackBook(first_id)
        self.state = np.zeros((0, LAYOUT.dim))

    @property
    def next_id(self) -> int:
        return self.book.next_id

    def reset(self, reset_ids: bool = False) -> int:
        self.state = np.zeros((0, LAYOUT.dim))
        return self.book.reset(reset_ids)

    def _scene_box(self, observation: Observation) -> np.ndarray | None:
        image, window = observation.image, observation.window
        if image is None or window is None:
            return None  # a needed input was lost: a missed frame
        box = red_box(image, self.min_pixels)
        if box is None:
            return None
        sx, sy = window.width / image.shape[1], window.height / image.shape[0]
        x, y, w, h = box
        return np.array([window.x + x * sx, window.y + y * sy, w * sx, h * sy])

    def step(self, observation: Observation) -> TrackSet:
        t, book = observation.time, self.book
        book.check_time(t)
        box = self._scene_box(observation)
        found = Detections.empty()
        if box is not None:
            centre = box[:2] + box[2:] / 2
            found = Detections(centre[None], [box[2] * box[3]], box[None], [1.0])
        rows = np.arange(min(len(book), len(found)))
        if rows.size:
            self.state[rows] = np.concatenate([found.positions[rows], found.bboxes[rows, 2:]], 1)
        updated = book.record_frame(rows, rows, found, LAYOUT.positions(self.state))
        book.confirm(updated)
        lost = book.misses >= self.max_misses
        if len(book) == 0 and len(found):
            new = np.array([0])
            book.add(t, found, new, np.array([True]))
            self.state = np.concatenate([found.positions, found.bboxes[:, 2:]], axis=1)
            updated, lost = np.array([True]), np.array([False])
        count = len(book)
        tracks = book.snapshot(
            t, LAYOUT, self.state.copy(), np.tile(np.eye(LAYOUT.dim), (count, 1, 1)),
            updated, lost, {},
        )  # fmt: skip
        if lost.any():
            book.keep(~lost)
            self.state = self.state[~lost]
        book.finish(t)
        return tracks


def build(values: Mapping[str, Any], first_id: int = 1) -> RedBlobTracker:
    return RedBlobTracker(values["min_pixels"], values["max_misses"], first_id)


METHOD: Method[Any] = Method(
    name="red_blob_test",
    description="test only: follows the red region of the camera image",
    build=build,
    parameters=(
        ParamSpec("min_pixels", 4, "fewest red pixels that make a target", 1, 100000),
        ParamSpec("max_misses", 2, "frames without red before the track is lost", 1, 100),
    ),
)
