"""How tall the followed objects are where they stand, learned from the tracks (no rclpy).

A camera looking down on a ground plane sees a person smaller the higher up the image they stand:
the height of their box grows about linearly with the row of its bottom edge (h = a + b y; the
horizon is where h reaches 0). `HeightByRow` fits that line to the boxes of confirmed tracks as
they are observed, robustly (Huber-weighted least squares: a box that held a strip of tape or
lost its legs is an outlier), and gives the least height a new track must have where it stands:
`ratio` x the line's height there. Clutter that drifts (a healing ghost, a leaf, a flickering
patch) is mostly far smaller than a person at its place; a person whose legs go unseen for a
frame is still more than half of one. Until `min_samples` boxes have been seen nothing is
required, so a camera's first movers are confirmed as before. A fit whose slope is not positive
(people taller the higher up they stand) cannot come from a camera above the ground and is not
taken: the first boxes of a scene can be a few people partly out of the view, whose boxes gave
lines falling by up to 0.7 px per row, and a target's expected height jumped from 126 to 320 px.

It also learns how wide the followed objects are for their height (`aspect`): a low quantile of
the boxes' width over height, as a box is widened, not narrowed, by what does not belong to one
object (two people walking in one blob, a shadow); a person's stride swings their width by
about a third either way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

HUBER_K = 1.345  # residuals beyond this many robust standard deviations are down-weighted
MAD_TO_STD = 1.4826
FIT_ITERATIONS = 4
#: the narrowest a box of one object is, as a share of its usual aspect (a person 100 px tall and
#: 40 px wide seen sideways, legs together: 0.3 of it)
NARROWEST = 0.25
#: the quantile of the observed boxes' width / height taken as one object's aspect (see above)
ASPECT_QUANTILE = 0.3


def robust_line(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(intercept, slope) of y = a + b x by iteratively reweighted least squares, Huber
    weights on residuals scaled by their median absolute deviation."""
    design = np.column_stack([np.ones_like(x), x])
    weights = np.ones_like(x)
    coefficients = np.zeros(2)
    for _ in range(FIT_ITERATIONS):
        root = np.sqrt(weights)
        coefficients = np.linalg.lstsq(design * root[:, None], y * root, rcond=None)[0]
        residuals = y - design @ coefficients
        scale = MAD_TO_STD * float(np.median(np.abs(residuals)))
        if scale <= 1e-9:
            break
        ratio = np.abs(residuals) / (HUBER_K * scale)
        weights = np.where(ratio <= 1.0, 1.0, 1.0 / np.maximum(ratio, 1e-12))
    return float(coefficients[0]), float(coefficients[1])


def bottom_rows(boxes: np.ndarray) -> np.ndarray:
    """The row (px) of each (x, y, width, height) box's bottom edge: where the object stands."""
    rows: np.ndarray = boxes[:, 1] + boxes[:, 3]
    return rows


class HeightByRow:
    """The height (px) of confirmed objects as a line in the row of their boxes' bottom edge.

    `observe` adds boxes (x, y, width, height); the newest `capacity` are kept. The line is
    refitted when `refit_every` boxes have arrived since the last fit."""

    def __init__(
        self,
        ratio: float,
        min_samples: int = 30,
        capacity: int = 2000,
        refit_every: int = 10,
    ) -> None:
        if not 0.0 <= ratio <= 1.0:
            raise ValueError(f"the height ratio must be in [0, 1], got {ratio}")
        if min_samples < 2 or capacity < min_samples or refit_every < 1:
            raise ValueError("need min_samples >= 2, capacity >= min_samples, refit_every >= 1")
        self.ratio, self.min_samples = ratio, min_samples
        self.capacity, self.refit_every = capacity, refit_every
        self.clear()

    def clear(self) -> None:
        self._rows = np.zeros(0)
        self._heights = np.zeros(0)
        self._widths = np.zeros(0)
        self._unfitted = 0
        # the widths and heights the line was fitted to (`observe` replaces, never changes, them)
        self._fitted: tuple[np.ndarray, np.ndarray] = (self._widths, self._heights)
        self.line: tuple[float, float] | None = None  # (intercept px, px per row)
        self._aspect: float | None = None  # of the boxes of the last fit, once asked for

    def __len__(self) -> int:
        return len(self._rows)

    def observe(self, boxes: np.ndarray) -> None:
        """Boxes (N, 4) of objects known to be what is followed (confirmed, observed now)."""
        if len(boxes) == 0:
            return
        self._rows = np.concatenate([self._rows, bottom_rows(boxes)])[-self.capacity :]
        self._heights = np.concatenate([self._heights, boxes[:, 3]])[-self.capacity :]
        self._widths = np.concatenate([self._widths, boxes[:, 2]])[-self.capacity :]
        self._unfitted += len(boxes)
        if len(self) >= self.min_samples and (
            self.line is None or self._unfitted >= self.refit_every
        ):
            line = robust_line(self._rows, self._heights)
            if line[1] > 0:  # else not a ground plane's (module doc): the last line stays
                self.line = line
                self._fitted = (self._widths, self._heights)
                self._aspect = None
            self._unfitted = 0

    @property
    def aspect(self) -> float | None:
        """One object's width / height (module doc) over the boxes of the last fit, None before
        it; worked out when first asked for (the height rule alone never asks)."""
        if self.line is None:
            return None
        if self._aspect is None:
            widths, heights = self._fitted
            aspects = widths / np.maximum(heights, 1.0)
            self._aspect = float(np.quantile(aspects, ASPECT_QUANTILE))
        return self._aspect

    def expected_heights(self, boxes: np.ndarray) -> np.ndarray:
        """The fitted height (px, at least 0) at each box's bottom row; 0 before the first fit."""
        if self.line is None:
            return np.zeros(len(boxes))
        intercept, slope = self.line
        return np.maximum(intercept + slope * bottom_rows(boxes), 0.0)

    def least_heights(self, boxes: np.ndarray) -> np.ndarray:
        """The height (px) each box (N, 4) needs to be taken for a followed object there."""
        return self.ratio * self.expected_heights(boxes)


def height_ratios(line: tuple[float, float], boxes: np.ndarray) -> np.ndarray:
    """Each box's (N, 4) height over the line's height at its bottom row; NaN at or above the
    horizon (where the line is under 1 px)."""
    intercept, slope = line
    at_boxes = intercept + slope * bottom_rows(boxes)
    result: np.ndarray = np.where(at_boxes >= 1.0, boxes[:, 3] / np.maximum(at_boxes, 1.0), np.nan)
    return result


@dataclass(frozen=True)
class ExpectedHeight:
    """How tall one object should be where a box of it stands: a ground line through that
    object's own box (h = intercept + slope x bottom row, px).

    `through` scales the learned line (`HeightByRow.line`, the typical object) to pass through a
    reference box of this one, `scaled` by a ratio such as the median of `height_ratios` over
    the boxes that measured it: a child or a crouching person keeps their own height, and a line
    biased by a few per cent (boxes with a shadow, pairs in one blob) cancels out; only the
    line's slope and horizon matter.

    `aspect` (optional): the width / height one such object rarely exceeds (`HeightByRow.aspect`);
    a wider box holds more than the object (a neighbour in the same blob)."""

    intercept: float
    slope: float
    aspect: float | None = None

    @classmethod
    def through(
        cls, line: tuple[float, float], reference: np.ndarray, row_offset: float = 0.0
    ) -> ExpectedHeight | None:
        """`line` scaled through the box `reference` (x, y, width, height), in the line's
        coordinates; the reference's row 0 is the line's row `row_offset` (it was seen in a
        window whose top is there). None when the reference stands at or above the horizon."""
        moved = np.asarray(reference, dtype=float) + [0.0, row_offset, 0.0, 0.0]
        return cls.scaled(line, float(height_ratios(line, moved[None])[0]))

    @classmethod
    def scaled(cls, line: tuple[float, float], ratio: float) -> ExpectedHeight | None:
        """`line` x `ratio` (the object's height over the typical one's; from `height_ratios`),
        None when the ratio is not a positive number (boxes at or above the horizon)."""
        if not (math.isfinite(ratio) and ratio > 0):
            return None
        intercept, slope = line
        return cls(ratio * intercept, ratio * slope)

    def shifted(self, rows: float) -> ExpectedHeight:
        """The same heights in coordinates whose row 0 is this line's row `rows` (a window)."""
        return ExpectedHeight(self.intercept + self.slope * rows, self.slope, self.aspect)

    def with_aspect(self, aspect: float | None) -> ExpectedHeight:
        """The same heights with the object's usual aspect (None: unknown)."""
        return ExpectedHeight(self.intercept, self.slope, aspect)

    def heights(self, boxes: np.ndarray) -> np.ndarray:
        """The expected height (px, at least 1) at each box's (N, 4) bottom row."""
        return np.maximum(self.intercept + self.slope * bottom_rows(boxes), 1.0)

    def likelihood(
        self, boxes: np.ndarray, spread: float, aspect_spread: float = 0.0
    ) -> np.ndarray:
        """exp(-(ln(h / expected h) / spread)^2 / 2) per box (N, 4): 1 at the expected height,
        0.61 one `spread` (a relative deviation, 0.1 = about 10 %) away; with `aspect_spread` > 0
        and a known `aspect`, times exp(-(max(ln(a / aspect), 0) / aspect_spread)^2 / 2) for the
        box's aspect a = w / h: one-sided, a narrow box is a person mid-stride or partly hidden,
        a wide one holds someone else too; and the same below `NARROWEST` x `aspect`, where a
        box is no longer a person but a post or the edge of a sign."""
        heights = np.maximum(boxes[:, 3], 1.0)
        deviation = (np.log(heights / self.heights(boxes)) / spread) ** 2
        if aspect_spread > 0 and self.aspect is not None and self.aspect > 0:
            log_aspect = np.log(np.maximum(boxes[:, 2], 1.0) / heights / self.aspect)
            wider = np.maximum(log_aspect, 0.0)
            narrower = np.maximum(math.log(NARROWEST) - log_aspect, 0.0)
            deviation = deviation + ((wider + narrower) / aspect_spread) ** 2
        result: np.ndarray = np.exp(-0.5 * deviation)
        return result
