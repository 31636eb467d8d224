"""Tell people apart inside one blob: a HOG people detector run in the blob (no rclpy).

Two people who walk half behind one another are one connected blob: their heads are too close
for the side-by-side cut (`side_by_side`) to find a dip between them, and the blob's box, over
both, matches neither. The mask cannot tell them apart; their image can. Dalal & Triggs'
histogram-of-oriented-gradients detector with OpenCV's default people SVM (trained on the INRIA
photographs: a person about 96 px tall in a 64 x 128 window) is run in a region around each blob
at least `MIN_BLOB_HEIGHT` px tall, `MIN_ASPECT` as wide as tall and not cut by the image's
top or bottom, scaled so that people from `MIN_SHARE` to `MAX_SHARE` of the blob's height fill
its window. Hits that overlap or nest are one person (the strongest); people must lie inside the
blob and be of one height.

When it finds two or more people, standing `SEPARATION` apart across and together spanning
`COVER` of the blob's width, each with an SVM margin of at least `MIN_MARGIN`, the blob is
replaced by one blob per person. Otherwise it stays as it is: one walker, or people the detector
cannot see (the one half hidden behind the other is often missed; the tracker still has the
blob).

A person's blob is the blob's own mask pixels within their box: their tight box, centroid and
count; a piece narrower than `MIN_PIECE_WIDTH` x the box (a leg: a walker's stride found as two
people) cancels the split. Whole-image HOG costs ~55 ms per 768 x 576 frame here; in the regions
of the few tall blobs in view it costs a few ms.
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from tracker_detect.detector import Blob
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect

WINDOW = (64, 128)  # px, the people SVM's window (width, height)
PERSON_IN_WINDOW = (0.25, 0.125, 0.5, 0.75)  # x, y, width, height of its person, x the window
MIN_SHARE = 0.6  # smallest person looked for, x the blob's height
MAX_SHARE = 1.1  # largest ...
MARGIN = 0.25  # the region around a blob, x its height on every side
MIN_BLOB_HEIGHT = 40  # image px: smaller blobs are left alone
# width / height: narrower blobs hold one person. One walker ~0.41, two side by side ~0.53, but
# two who walk one half behind the other make a blob as narrow as 0.36
MIN_ASPECT = 0.3
EDGE = 0.05  # x the image height: a blob this close to its top or bottom is cut by it
MIN_MARGIN = 0.5  # SVM margin every person of a split needs (a walker's stride or a post: lower)
SCALE_STEP = 1.1  # between pyramid levels (1.05: twice the time, no more people found)
NMS_IOU = 0.4  # two hits overlapping more are one person (staggered pairs overlap ~0.3)
NESTED = 0.6  # ... and so are two of which this share of the smaller lies inside the larger
SIMILAR_HEIGHT = 0.75  # people in one blob stand side by side: at least this x the tallest
SEPARATION = 0.5  # x their mean width: centres of people in one blob lie at least this far apart
INSIDE = 0.7  # share of a person's box that lies inside the blob's box
MIN_PIECE_WIDTH = 0.6  # x the person's box: the mask pixels in it are as wide as a body
MIN_PIXELS = 0.15  # share of a person's box the blob's mask fills for a piece to stand
HOLD_FRAMES = 5  # a split is held this many frames after HOG last found its people
HOLD_IOU = 0.5  # ... on the blob that overlaps the split one this much (scene boxes)
COVER = 0.7  # the people found span at least this share of the blob's width


@dataclass(frozen=True)
class Person:
    """A person found in an image: their box (image px) and the SVM's margin."""

    box: Rect
    weight: float


class PeopleDetector:
    """OpenCV's HOG people detector, run in one region of an image at a chosen size.

    With `threads` 2 the pyramid's levels are shared between the calling thread and one worker
    (HOG's C++ releases the interpreter lock): on a 2-core machine a blob's levels take about
    0.6 x the time while the rest of a lockstep graph waits for the detections. The hits are
    gathered level by level in the same order either way, so the result is the same."""

    def __init__(self, hit_threshold: float = 0.0, threads: int = 2) -> None:
        if threads not in (1, 2):
            raise ValueError(f"threads must be 1 or 2, got {threads}")
        self.hit_threshold = hit_threshold
        self._hogs = [_people_hog() for _ in range(threads)]  # one per thread
        self._worker = ThreadPoolExecutor(1, "hog") if threads == 2 else None

    def find(
        self, image: np.ndarray, region: Rect, person_heights: tuple[float, float]
    ) -> list[Person]:
        """People from `person_heights[0]` to `[1]` px tall whose windows lie in `region` (image
        px, clipped to the image), strongest first, overlapping hits merged."""
        height, width = image.shape[:2]
        u0, v0 = max(0, int(region.x)), max(0, int(region.y))
        u1 = min(width, int(np.ceil(region.x + region.width)))
        v1 = min(height, int(np.ceil(region.y + region.height)))
        smallest, largest = person_heights
        zoom = WINDOW[1] * PERSON_IN_WINDOW[3] / smallest  # the smallest person fills a window
        patch = image[v0:v1, u0:u1]
        size = (round(patch.shape[1] * zoom), round(patch.shape[0] * zoom))
        if size[0] < WINDOW[0] or size[1] < WINDOW[1]:
            return []
        scaled = cv2.resize(patch, size, interpolation=cv2.INTER_LINEAR)
        found = [
            Person(_person_box(window, zoom, u0, v0), weight)
            for window, weight in self._windows(scaled)
        ]
        return _suppress(found)

    def _windows(self, image: np.ndarray) -> list[tuple[tuple[int, int, int, int], float]]:
        """The SVM's hits (window x, y, width, height in `image` px; margin) over an image
        pyramid of step SCALE_STEP, as OpenCV's detectMultiScale without grouping finds them.

        The levels are gathered in level order: detectMultiScale runs its levels in OpenCV's
        worker threads, and now and then (about one replay in ten, more often on a busy
        machine) returned other hits for the same image, so a replay's tracks changed from
        one run to the next."""
        scales = _level_scales(image.shape[1], image.shape[0], self._hogs[0].nlevels)
        if self._worker is None or len(scales) < 2:
            by_level = self._levels(self._hogs[0], image, scales)
        else:  # every other level to the worker: the largest and the smallest spread over both
            theirs = self._worker.submit(self._levels, self._hogs[1], image, scales[1::2])
            by_level = [[] for _ in scales]
            by_level[0::2] = self._levels(self._hogs[0], image, scales[0::2])
            by_level[1::2] = theirs.result()
        return [hit for hits in by_level for hit in hits]

    def _levels(
        self, hog: cv2.HOGDescriptor, image: np.ndarray, scales: list[float]
    ) -> list[list[tuple[tuple[int, int, int, int], float]]]:
        """Per pyramid level, the hits found in `image` shrunk by that level's scale."""
        rows, cols = image.shape[:2]
        found = []
        for scale in scales:
            size = (round(cols / scale), round(rows / scale))  # cvRound: half to even
            level = (
                image
                if size == (cols, rows)
                else cv2.resize(image, size, interpolation=cv2.INTER_LINEAR_EXACT)
            )
            corners, weights = hog.detect(
                level, hitThreshold=self.hit_threshold, winStride=(8, 8), padding=(0, 0)
            )
            window = (round(WINDOW[0] * scale), round(WINDOW[1] * scale))
            hits = [
                ((round(x * scale), round(y * scale), *window), float(weight))
                for (x, y), weight in zip(
                    np.asarray(corners).reshape(-1, 2), np.ravel(weights), strict=True
                )
            ]
            found.append(hits)
        return found


def _people_hog() -> cv2.HOGDescriptor:
    hog = cv2.HOGDescriptor()
    hog.setSVMDetector(np.asarray(cv2.HOGDescriptor.getDefaultPeopleDetector(), np.float32))
    return hog


def _level_scales(cols: int, rows: int, levels: int) -> list[float]:
    """The pyramid's scales, SCALE_STEP apart from 1, while a level still holds a window."""
    scales, scale = [], 1.0
    for _ in range(levels):
        if round(cols / scale) < WINDOW[0] or round(rows / scale) < WINDOW[1]:
            break
        scales.append(scale)
        scale *= SCALE_STEP
    return scales


def _person_box(window: Sequence[int], zoom: float, u0: int, v0: int) -> Rect:
    """The person's box in image px from a detection window in the scaled region."""
    x, y, w, h = (float(v) for v in window)
    px, py, pw, ph = PERSON_IN_WINDOW
    return Rect(u0 + (x + px * w) / zoom, v0 + (y + py * h) / zoom, pw * w / zoom, ph * h / zoom)


def _suppress(people: list[Person]) -> list[Person]:
    """Greedy non-maximum suppression: the strongest of hits that overlap by NMS_IOU or of which
    one lies NESTED inside the other (a person's upper body or legs, found at a smaller scale).

    Hits of equal margin (the same window content at two pyramid levels scores to the last bit)
    go smallest first, then top to bottom and left to right: OpenCV returns the levels in the
    order its threads finish them, and a tie broken by that order changed the tracks from one
    run of a replay to the next."""
    kept: list[Person] = []
    order = sorted(people, key=lambda p: (-p.weight, p.box.height, p.box.y, p.box.x, p.box.width))
    for person in order:
        if all(not _same_person(person.box, other.box) for other in kept):
            kept.append(person)
    return kept


def _same_person(a: Rect, b: Rect) -> bool:
    common = a.intersection_area(b)
    return common >= NMS_IOU * (a.area + b.area - common) or common >= NESTED * min(a.area, b.area)


class PeopleSplitter:
    """Replaces each blob that holds two or more people by one blob per person (module doc).

    A split is held: when HOG no longer finds the people of a blob it split in the last
    `HOLD_FRAMES` frames (the one half behind is found in some frames and not in others), the
    blob that overlaps that one most (IoU >= HOLD_IOU, scene px) is split at the same people's
    boxes, moved with the blob's centre. Tracks of the people then see them every frame instead
    of flickering between one blob and two.
    """

    def __init__(self, detector: PeopleDetector | None = None) -> None:
        self.detector = detector or PeopleDetector()
        self._splits: list[_Split] = []

    def reset(self) -> None:
        """Forget the splits held."""
        self._splits = []

    def split(
        self, blobs: list[Blob], image: np.ndarray, mask: np.ndarray, view: View
    ) -> list[Blob]:
        """`blobs` with the people in them apart; `image` and `mask` (uint8, nonzero =
        foreground) are the camera's, in image px."""
        result: list[Blob] = []
        splits: list[_Split] = []
        for blob in blobs:
            box = view.rect_to_image(blob.bbox)
            people, age = _people_in(box, image, self.detector), 0
            if not people:
                people, age = self._held(blob.bbox, view)
            pieces = [_piece(blob, box, person, mask, view) for person in people]
            kept = [piece for piece in pieces if piece is not None]
            if len(people) >= 2 and len(kept) == len(people):
                result.extend(kept)
                scene_boxes = [view.rect_to_scene(p.x, p.y, p.width, p.height) for p in people]
                splits.append(_Split(blob.bbox, scene_boxes, age))
            else:
                result.append(blob)
        self._splits = [s for s in splits if s.age < HOLD_FRAMES]
        result.sort(key=lambda b: (-b.pixel_count, b.centroid_y, b.centroid_x))
        return result

    def _held(self, box: Rect, view: View) -> tuple[list[Rect], int]:
        """The people (image px) of the held split that overlaps `box` (scene px) most, moved
        with it, and the frames since HOG found them; ([], 0) when none overlaps enough."""
        best = max(self._splits, key=lambda s: s.blob.iou(box), default=None)
        if best is None or best.blob.iou(box) < HOLD_IOU:
            return [], 0
        (x, y), (split_x, split_y) = box.center, best.blob.center
        dx, dy = x - split_x, y - split_y
        moved = [Rect(p.x + dx, p.y + dy, p.width, p.height) for p in best.people]
        return [view.rect_to_image(p) for p in moved], best.age + 1


@dataclass(frozen=True)
class _Split:
    blob: Rect  # scene px: the blob's box when it was split
    people: list[Rect]  # scene px: the people's boxes in it
    age: int  # frames since HOG found them


def _people_in(box: Rect, image: np.ndarray, detector: PeopleDetector) -> list[Rect]:
    """The boxes (image px) of the people HOG finds in a blob's `box` (image px) when there are
    two or more that pass the module doc's tests, else []."""
    edge = EDGE * image.shape[0]
    if (
        box.height < MIN_BLOB_HEIGHT
        or box.width < MIN_ASPECT * box.height
        or box.y < edge
        or box.y + box.height > image.shape[0] - edge
    ):
        return []
    margin = MARGIN * box.height
    region = Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin)
    people = detector.find(image, region, (MIN_SHARE * box.height, MAX_SHARE * box.height))
    inside = [p for p in people if p.box.intersection_area(box) >= INSIDE * p.box.area]
    if inside:
        tallest = max(p.box.height for p in inside)
        inside = [p for p in inside if p.box.height >= SIMILAR_HEIGHT * tallest]
    if len(inside) < 2 or not _apart(inside) or min(p.weight for p in inside) < MIN_MARGIN:
        return []
    left = min(p.box.x for p in inside)
    right = max(p.box.x + p.box.width for p in inside)
    if min(right, box.x + box.width) - max(left, box.x) < COVER * box.width:
        return []  # people found in a part of it: a bush or a sign that HOG took for people
    return [p.box for p in inside]


def _apart(people: list[Person]) -> bool:
    """Whether every two people's centres are SEPARATION x their mean width apart across: a
    walker's stride or swinging arm gives a second hit at nearly the same place."""
    centres = sorted((p.box.x + p.box.width / 2.0, p.box.width) for p in people)
    return all(
        b[0] - a[0] >= SEPARATION * (a[1] + b[1]) / 2.0
        for a, b in zip(centres, centres[1:], strict=False)
    )


def _piece(blob: Blob, box: Rect, person: Rect, mask: np.ndarray, view: View) -> Blob | None:
    """The blob's mask pixels within `person`'s box (both image px), as a blob."""
    common = person.intersection(box)
    if common is None:
        return None
    u0, v0 = int(round(common.x)), int(round(common.y))
    u1, v1 = int(round(common.x + common.width)), int(round(common.y + common.height))
    ys, xs = np.nonzero(mask[v0:v1, u0:u1])
    n = len(xs)
    if n < MIN_PIXELS * max(common.area, 1.0):
        return None
    x, y = int(xs.min()), int(ys.min())
    w, h = int(xs.max()) - x + 1, int(ys.max()) - y + 1
    if w < MIN_PIECE_WIDTH * common.width:
        return None  # a leg or an arm: a walker's stride found as two people
    cx, cy = view.to_scene(u0 + float(xs.mean()) + 0.5, v0 + float(ys.mean()) + 0.5)
    return Blob(
        cx,
        cy,
        view.rect_to_scene(u0 + x, v0 + y, w, h),
        n * view.scale_x * view.scale_y,
        n,
        blob.score,
    )
