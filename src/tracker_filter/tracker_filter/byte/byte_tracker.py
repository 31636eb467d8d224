"""Tracking on scored boxes, in the manner of ByteTrack (Zhang et al., ECCV 2022), no rclpy.

A `tracking.Tracker` (method `byte`) for a detector whose boxes are objects with a confidence
score, higher = surer (the `person` detector). What it needs once detections are good is little:

1. every track predicts its box with a constant-velocity Kalman filter on the box's centre and
   size (`BoxKalman`);
2. the confident boxes (score >= `high`) go to the tracks, confirmed ones and ones missed for up
   to `max_misses` frames, by the Hungarian assignment on IoU with the predicted boxes
   (>= `match_iou`);
3. with `refind_similarity` > 0 (the tracker then needs the camera image and window), the
   confident boxes left go to the tracks missed for a frame or more whose colours they match
   (`appearance`: hue-saturation histograms of the box's upper and lower half, Bhattacharyya
   coefficient >= `refind_similarity`) within `refind_reach` heights of their predicted box per
   second missed (a frame's interval counted for the frame they are found in): a person coming
   out from behind the sign or another person, where a constant-velocity box has gone on without
   them. The reach is a walker's: at 1.5 heights a second a person who turned round inside the
   gap is still reached, while one who walks in from elsewhere after a few seconds is not taken
   for them on colours alone;
4. the weak boxes (`low` <= score < `high`: a person half hidden, blurred, small) go to the
   confirmed tracks still unmatched, by IoU (>= `weak_iou`): they continue a track, never start
   one;
5. the tentative tracks take the confident boxes left (>= `match_iou`);
6. a confident box still left starts a tentative track, confirmed after `confirm_hits` hits in a
   row (a tentative track missed once is dropped: one false box never becomes a track); a
   confirmed track missed for more than `max_misses` frames is LOST.

A box is matched only with tracks of its label (as Frigate tracks each label apart): from the
`person_motion` detector, person boxes make person tracks and the motion blobs no person explains
make motion tracks (a flag, a car), which target selection leaves alone unless told to follow
them; a motion blob on a person the model misses for a moment does not take their track over.

No travel or straightness rule: a person standing still is a person. Layout "x y vx vy": the box
centre and its velocity (px, px/s); each track's box is its filter's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from tracker_filter.colour_histograms import ColourSpace, bin_image, clip_bounds, histogram
from tracker_filter.layout import StateLayout
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.geometry import iou_matrix
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

LAYOUT = StateLayout.from_names("x y vx vy")
FIRST_INTERVAL = 0.1  # s, assumed before the second frame tells the real one
LOOK_MEMORY = 0.9  # a track's colours: this share of what they were, the rest the new box's


@dataclass(frozen=True)
class ByteConfig:
    high: float = param(
        0.5, "a box at least this confident is matched first, may start a track", min=0.0, max=1.0
    )
    low: float = param(
        0.2, "weaker boxes (but at least this) only continue confirmed tracks", min=0.0, max=1.0
    )
    match_iou: float = param(
        0.2, "least IoU of a confident box with a track's predicted box", min=0.01, max=1.0
    )
    weak_iou: float = param(
        0.5, "least IoU of a weak box with a track's predicted box", min=0.01, max=1.0
    )
    confirm_hits: int = param(3, "hits in a row that confirm a track", min=1, max=100)
    max_misses: int = param(
        20, "frames a confirmed track may go unmatched before it is LOST", min=0, max=10000
    )
    position_noise: float = param(
        0.05,
        "box centre and size noise per frame",
        min=1e-4,
        max=10.0,
        unit="share of its height",
    )
    velocity_noise: float = param(
        0.00625,
        "their rates' noise per frame",
        min=1e-5,
        max=10.0,
        unit="share of its height",
    )
    refind_similarity: float = param(
        0.8,
        "colours (Bhattacharyya coefficient) a missed track's box must match to be found again "
        "(0: no appearance; > 0: the tracker needs the camera image)",
        min=0.0,
        max=1.0,
    )
    refind_reach: float = param(
        1.5,
        "... within this many heights of its prediction per second missed",
        min=0.0,
        max=100.0,
    )
    max_tracks: int = param(100, "tracks kept at most", min=1, max=100000)

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        if self.low > self.high:
            return [f"need low <= high, got low {self.low}, high {self.high}"]
        return []


class BoxKalman:
    """Constant-velocity Kalman filters of N boxes, state (cx, cy, w, h, vcx, vcy, vw, vh) in px
    and px/s, measurement (cx, cy, w, h); noise standard deviations in proportion to each box's
    height (DeepSORT's and ByteTrack's choice: a near, tall person moves more px per frame).

        predict:  x = F x,            P = F P F' + Q        F = [[I, dt I], [0, I]]
        update:   K = P H' (H P H' + R)^-1,  x += K (z - H x),  P = (I - K H) P
    """

    def __init__(self, position_noise: float, velocity_noise: float) -> None:
        self.position_noise = position_noise
        self.velocity_noise = velocity_noise
        self.means = np.zeros((0, 8))
        self.covariances = np.zeros((0, 8, 8))

    def add(self, boxes: np.ndarray, interval: float) -> None:
        """New filters at (N, 4) boxes x, y, w, h, standing still, unsure of their velocity."""
        z = _measurement(boxes)
        h = z[:, 3:4]
        std = np.hstack(
            [2 * self.position_noise * h.repeat(4, 1), 10 * self.velocity_noise * h.repeat(4, 1)]
        )
        std[:, 4:] /= interval
        self.means = np.vstack([self.means, np.hstack([z, np.zeros_like(z)])])
        self.covariances = np.concatenate([self.covariances, _diagonals(std**2)])

    def predict(self, dt: float) -> None:
        if not len(self.means):
            return
        F = np.eye(8)
        F[:4, 4:] = dt * np.eye(4)
        h = self.means[:, 3:4]
        std = np.hstack(
            [self.position_noise * h.repeat(4, 1), self.velocity_noise * h.repeat(4, 1) / dt]
        )
        self.means = self.means @ F.T
        self.covariances = F @ self.covariances @ F.T + _diagonals(std**2)
        self.means[:, 2:4] = np.maximum(self.means[:, 2:4], 1.0)  # a box never shrinks to none

    def update(self, rows: np.ndarray, boxes: np.ndarray) -> None:
        if not len(rows):
            return
        z = _measurement(boxes)
        x, P = self.means[rows], self.covariances[rows]
        R = _diagonals((self.position_noise * z[:, 3:4].repeat(4, 1)) ** 2)
        S = P[:, :4, :4] + R
        K = P[:, :, :4] @ np.linalg.inv(S)
        innovation = z - x[:, :4]
        self.means[rows] = x + np.einsum("nij,nj->ni", K, innovation)
        self.covariances[rows] = P - K @ P[:, :4, :]

    def boxes(self) -> np.ndarray:
        """(N, 4) boxes x, y, w, h of the filters' means."""
        c, size = self.means[:, :2], self.means[:, 2:4]
        return np.hstack([c - size / 2, size])

    def keep(self, mask: np.ndarray) -> None:
        self.means, self.covariances = self.means[mask], self.covariances[mask]

    def clear(self) -> None:
        self.keep(np.zeros(len(self.means), dtype=bool))


def _measurement(boxes: np.ndarray) -> np.ndarray:
    """(N, 4) x, y, w, h boxes as (cx, cy, w, h)."""
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    return np.hstack([boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2:]])


def _diagonals(variances: np.ndarray) -> np.ndarray:
    """(N, k) variances as (N, k, k) diagonal matrices."""
    out = np.zeros(variances.shape + variances.shape[-1:])
    index = np.arange(variances.shape[-1])
    out[:, index, index] = variances
    return out


def _assign(
    predicted: np.ndarray, boxes: np.ndarray, threshold: float, allowed: np.ndarray
) -> list[tuple[int, int]]:
    """Pairs (track row, box row) by the Hungarian assignment on IoU, each pair >= threshold and
    `allowed` (tracks x boxes)."""
    if not len(predicted) or not len(boxes):
        return []
    overlap = np.where(allowed, iou_matrix(predicted, boxes), 0.0)
    rows, cols = linear_sum_assignment(-overlap)
    return [(int(r), int(c)) for r, c in zip(rows, cols, strict=True) if overlap[r, c] >= threshold]


APPEARANCE_BINS = 8  # per channel of the hue-saturation histograms
PARTS = 2  # the box's upper and lower half: a coat and trousers


def appearance(image: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(N, PARTS * K^2) hue-saturation histograms of each (image px) box's upper and lower half,
    each normalised, of the middle 60 % of its width and 10-90 % of its height (less
    background, no hair-line shifts)."""
    bins = bin_image(image, ColourSpace.HSV, APPEARANCE_BINS)
    count = APPEARANCE_BINS**2
    out = np.zeros((len(boxes), PARTS * count))
    for i, (x, y, w, h) in enumerate(np.asarray(boxes, float).reshape(-1, 4)):
        for part in range(PARTS):
            top = y + h * (0.1 + 0.8 * part / PARTS)
            inner = np.array([[x + 0.2 * w, top, 0.6 * w, 0.8 * h / PARTS]])
            bounds = clip_bounds(inner, image.shape)[0]
            out[i, part * count : (part + 1) * count] = histogram(bins, bounds, count)
    return out


def similarity(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) Bhattacharyya coefficients of appearances, averaged over the parts."""
    root_a, root_b = np.sqrt(np.asarray(a)), np.sqrt(np.asarray(b))
    coefficients: np.ndarray = (root_a @ root_b.T) / PARTS
    return coefficients


class ByteTracker:
    """See the module docstring."""

    layout = LAYOUT

    def __init__(self, config: ByteConfig, first_id: int = 1) -> None:
        self.config = config
        self.kalman = BoxKalman(config.position_noise, config.velocity_noise)
        self.book = TrackBook(first_id)
        self.interval = FIRST_INTERVAL
        self.looks = np.zeros((0, PARTS * APPEARANCE_BINS**2))  # per track, its colours (EMA)

    @property
    def needs(self) -> frozenset[Need]:
        if self.config.refind_similarity > 0:
            return frozenset({Need.IMAGE, Need.WINDOW})
        return frozenset()

    @property
    def next_id(self) -> int:
        return self.book.next_id

    def reset(self, reset_ids: bool = False) -> int:
        self.kalman.clear()
        self.looks = self.looks[:0]
        return self.book.reset(reset_ids)

    def step(self, observation: Observation) -> TrackSet:
        t, book, c = observation.time, self.book, self.config
        book.check_time(t)
        detections, rejected = observation.detections.validated()
        if book.time is not None:
            self.interval = t - book.time
        self.kalman.predict(self.interval)
        predicted = self.kalman.boxes()
        scores = detections.scores
        high = np.flatnonzero(scores >= c.high)
        weak = np.flatnonzero((scores >= c.low) & (scores < c.high))
        confirmed = np.flatnonzero(book.confirmed)
        tentative = np.flatnonzero(~book.confirmed)

        looks = self._looks(observation, detections)
        pairs: list[tuple[int, int]] = []
        left_high = self._match(confirmed, high, predicted, detections, c.match_iou, pairs)
        if looks is not None:
            left_high = self._refind(left_high, predicted, detections, looks, pairs)
        missed = np.array([r for r in confirmed if r not in {p[0] for p in pairs}], dtype=int)
        self._match(missed, weak, predicted, detections, c.weak_iou, pairs)
        left_high = self._match(tentative, left_high, predicted, detections, c.match_iou, pairs)
        rows = np.array([r for r, _ in pairs], dtype=np.int64)
        cols = np.array([d for _, d in pairs], dtype=np.int64)

        self.kalman.update(rows, detections.bboxes[cols])
        if looks is not None:
            sure = scores[cols] >= c.high  # a weak box is often a part, or two people
            fresh = self.looks[rows[sure]].sum(axis=1) == 0
            blend = np.where(fresh, 0.0, LOOK_MEMORY)[:, None]
            self.looks[rows[sure]] = (
                blend * self.looks[rows[sure]] + (1 - blend) * looks[cols[sure]]
            )
        updated = book.record_frame(rows, cols, detections, self.kalman.means[:, :2])
        book.confirm((book.hits >= c.confirm_hits) & (book.hits == book.frames))
        lost = np.where(book.confirmed, book.misses > c.max_misses, ~updated)

        room = max(0, c.max_tracks - (len(book) - int(lost.sum())))
        new = left_high[:room]
        if len(new):
            self.kalman.add(detections.bboxes[new], self.interval)
            fresh = looks[new] if looks is not None else np.zeros((len(new), self.looks.shape[1]))
            self.looks = np.vstack([self.looks, fresh])
            book.add(t, detections, new, np.full(len(new), c.confirm_hits <= 1))
        updated = np.concatenate([updated, np.ones(len(new), dtype=bool)])
        lost = np.concatenate([lost, np.zeros(len(new), dtype=bool)])

        means = self.kalman.means
        tracks = book.snapshot(
            t,
            LAYOUT,
            means[:, [0, 1, 4, 5]].copy(),
            self.kalman.covariances[:, [0, 1, 4, 5]][:, :, [0, 1, 4, 5]].copy(),
            updated,
            lost,
            rejected,
        )
        tracks = replace(tracks, bboxes=self.kalman.boxes())
        if not (~lost).all():
            self.kalman.keep(~lost)
            self.looks = self.looks[~lost]
            book.keep(~lost)
        book.finish(t)
        return tracks

    def _looks(self, observation: Observation, detections: Detections) -> np.ndarray | None:
        """The detections' appearances (None: appearance off, or no image or window this frame,
        in which case the frame is matched by IoU alone)."""
        image, window = observation.image, observation.window
        if self.config.refind_similarity <= 0 or image is None or window is None:
            return None
        if window.width <= 0 or image.ndim != 3:
            return None
        scale = image.shape[1] / window.width
        boxes = detections.bboxes.copy()
        boxes[:, :2] -= (window.x, window.y)
        return appearance(image, boxes * scale)

    def _refind(
        self,
        candidates: np.ndarray,
        predicted: np.ndarray,
        detections: Detections,
        looks: np.ndarray,
        pairs: list[tuple[int, int]],
    ) -> np.ndarray:
        """Give `candidates` to missed tracks they look like, near enough (module docstring)."""
        c, book = self.config, self.book
        taken = {r for r, _ in pairs}
        missed = np.array(
            [r for r in np.flatnonzero(book.confirmed & (book.misses >= 1)) if r not in taken],
            dtype=np.int64,
        )
        if not len(missed) or not len(candidates):
            return candidates
        centre = predicted[missed, :2] + predicted[missed, 2:] / 2
        found = detections.bboxes[candidates]
        distance = np.hypot(
            *(centre[:, None] - (found[None, :, :2] + found[None, :, 2:] / 2)).transpose(2, 0, 1)
        )
        seconds = (book.misses[missed, None] + 1) * self.interval
        reach = c.refind_reach * predicted[missed, 3:4] * seconds
        alike = similarity(self.looks[missed], looks[candidates])
        good = (distance <= reach) & (alike >= c.refind_similarity)
        good &= self._same_label(missed, detections.labels[candidates])
        rows, cols = linear_sum_assignment(-np.where(good, alike, 0.0))
        chosen = [
            (int(missed[r]), int(candidates[k]))
            for r, k in zip(rows, cols, strict=True)
            if good[r, k]
        ]
        pairs += chosen
        used = {d for _, d in chosen}
        return np.array([d for d in candidates if int(d) not in used], dtype=np.int64)

    def _same_label(self, tracks: np.ndarray, labels: np.ndarray) -> np.ndarray:
        """(tracks x boxes) whether the track rows and the boxes' labels agree."""
        result: np.ndarray = self.book.labels[tracks][:, None] == labels[None, :]
        return result

    def _match(
        self,
        tracks: np.ndarray,
        candidates: np.ndarray,
        predicted: np.ndarray,
        detections: Detections,
        threshold: float,
        pairs: list[tuple[int, int]],
    ) -> np.ndarray:
        """Assign `candidates` (detection rows) to `tracks` (track rows) by IoU, adding the pairs
        to `pairs`; the candidates no track took, best score first."""
        same = self._same_label(tracks, detections.labels[candidates])
        found = _assign(predicted[tracks], detections.bboxes[candidates], threshold, same)
        pairs += [(int(tracks[r]), int(candidates[k])) for r, k in found]
        taken = {int(candidates[k]) for _, k in found}
        left = np.array([d for d in candidates if int(d) not in taken], dtype=np.int64)
        return left[np.argsort(-detections.scores[left], kind="stable")]


METHOD: Method[Any] = Method.of(
    name="byte",
    description="scored boxes in the manner of ByteTrack: a Kalman filter per box, confident "
    "boxes matched by IoU first, weak ones only to confirmed tracks, confirmation by hits",
    config=ByteConfig,
    make=ByteTracker,
)
