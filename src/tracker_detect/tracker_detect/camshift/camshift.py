"""CamShift colour tracking (seed 001, Bradski 1998) on a moving pan-tilt view (no rclpy).

The thesis pipeline, per frame: BGR -> HSV; the hue histogram of the selected rectangle (32 bins
over [0, 180), only pixels whose S >= s_min and v_min <= V <= v_max) normalised to max 255 is
back-projected, ANDed with the same S/V mask, and `cv2.CamShift` climbs it from the previous
window (at most `max_iterations` mean-shift steps or a shift below `epsilon` px). The result is a
rotated box (centre, size, angle) and its score.

Beyond the thesis:
- the histogram is background-weighted by default (Comaniciu, Ramesh & Meer 2003): a colour
  that is common in the selection's surroundings (grass around a green shirt, the pavement
  around a grey coat) is down-weighted, so the back-projection lights the target and not the
  street; `background_weighting` false is the thesis's plain histogram. A hue x saturation
  histogram is optional (`saturation_bins`);
- the reported box is the selected box carried by the found colours: the selection's offset
  and size relative to its colours' centroid and 4-sigma extent are kept and applied to the
  colours found in each frame, so a person whose shirt alone carries the colour is still
  reported with the whole box the user drew (CamShift's own rotated box rides along);
- the window lives in scene coordinates, so a panning camera does not drag it along; only a
  search region around it is converted to HSV (the whole image while re-acquiring);
- `guide(centre)` places the next search window at a filter's prediction (the thesis's future
  work) instead of at the last position;
- a window whose back-projection is empty or thin is a miss, not a position (OpenCV then
  returns a window at (0, 0) or drifts over the background): the mean back-projection in the
  found box must reach `min_density_ratio` of the density the model had in the selected region;
- after `lost_after` consecutive misses the target is lost: each frame the whole image is
  searched for the window-sized region of highest back-projection density, and CamShift is
  restarted there once that density is back above the threshold (re-acquisition).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tracker_detect.detector import Blob, CameraFrame, Detection, StaleFrameError
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.histograms import background_weights
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

HUE_RANGE = 180  # OpenCV's 8-bit hue convention: [0, 180)
SAME_TARGET_IOU = 0.3  # a handed-over box overlapping the tracked one this much is the same target


@dataclass(frozen=True)
class CamShiftConfig:
    """Parameters; the defaults are the thesis's (OpenCV camshiftdemo) where it gives them."""

    hue_bins: int = param(32, "bins of the hue histogram over [0, 180) (seed: 32)", min=2, max=180)
    saturation_bins: int = param(
        0,
        "0: a hue histogram (seed); else also this many saturation bins (a hue x saturation one)",
        min=0,
        max=256,
        validator=lambda v: None if v != 1 else "saturation_bins must be 0 or in [2, 256]",
    )
    background_weighting: bool = param(
        True,
        "down-weight the colours of the selection's surroundings (Comaniciu's background-"
        "weighted histogram; false: the seed's plain histogram)",
    )
    background_margin: float = param(
        1.0, "surroundings: the selection grown by this x its size on each side", min=0.05, max=10.0
    )
    v_min: int = param(10, "pixels darker than this are ignored (seed: 10)", min=0, max=256)
    v_max: int = param(256, "pixels brighter than this are ignored (seed: 256)", min=0, max=256)
    s_min: int = param(30, "pixels less saturated than this are ignored (seed: 30)", min=0, max=255)
    max_iterations: int = param(10, "mean-shift steps per frame at most", min=1, max=100)
    epsilon: float = param(
        1.0, "mean shift stops when the window moves less", min=0.01, max=100.0, unit="px"
    )
    search_margin: float = param(
        1.0, "search region: the window grown by this x its size on each side", min=0.0, max=10.0
    )
    min_density_ratio: float = param(
        0.3,
        "a found box whose mean back-projection is below this x the selection's is a miss",
        min=0.0,
        max=1.0,
    )
    lost_after: int = param(
        5,
        "consecutive misses after which the whole image is searched (re-acquisition)",
        min=1,
        max=100000,
    )
    max_size_ratio: float = param(
        4.0,
        "a box larger than this x the selection's side is a miss (spread over the background)",
        min=1.01,
        max=100.0,
    )
    min_model_pixels: int = param(
        20, "coloured pixels (passing the S/V limits) a selection needs", min=1, max=1_000_000
    )
    min_contrast: float = param(
        3.0,
        "a selection whose mean back-projection is below this x its surroundings' is refused: its "
        "colours do not stand out (0: no check)",
        min=0.0,
        max=1000.0,
    )
    min_similarity: float = param(
        0.6,
        "a found box whose colours match the model's less (Bhattacharyya coefficient of the "
        "plain histograms) is a miss: CamShift slid onto a like-coloured background (0: no check)",
        min=0.0,
        max=1.0,
    )
    rehandover_similarity: float = param(
        0.6,
        "while tracking, a handed-over box apart from the tracked one is taken when its colours "
        "match the model at least this well (Bhattacharyya) and better than the tracked box's "
        "(0: never)",
        min=0.0,
        max=1.0,
    )

    def problems(self) -> list[str]:
        """What is wrong with these values beyond their own ranges (empty when usable)."""
        if self.v_min > self.v_max:
            return [f"v_min ({self.v_min}) must not exceed v_max ({self.v_max})"]
        return []


@dataclass(frozen=True)
class BoxCalibration:
    """How the selected box relates to its colour distribution, in units of the distribution's
    4-sigma extent: a target whose colours fill only part of it (a blue pair of jeans under a
    shirt of the grass's colour) is still reported with the box the user drew."""

    offset: tuple[float, float]  # (box centre - colour centroid) / 4 sigma, per axis
    scale: tuple[float, float]  # box side / 4 sigma, per axis

    def box(self, spread: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
        """Box centre x, y and size w, h for a colour centroid and 4-sigma extent (cx, cy, ex, ey)."""
        cx, cy, ex, ey = spread
        return (
            cx + self.offset[0] * ex,
            cy + self.offset[1] * ey,
            self.scale[0] * ex,
            self.scale[1] * ey,
        )


@dataclass(frozen=True)
class ColourModel:
    """The target's colour histogram (normalised to max 255), its density in the selection and
    how the selected box sits on the colours."""

    histogram: np.ndarray  # (hue_bins[, saturation_bins]) float32
    density: float  # mean back-projection / 255 over the selected region
    size: tuple[float, float]  # selected width, height [scene px]
    calibration: BoxCalibration
    reference: (
        np.ndarray
    )  # the selection's plain colour histogram, summing to 1 (re-identification)


@dataclass(frozen=True)
class OrientedBox:
    """CamShift's rotated box in scene px; angle in rad from the scene x axis towards y."""

    cx: float
    cy: float
    width: float
    height: float
    angle: float

    @property
    def bounds(self) -> Rect:
        """The axis-aligned box around it."""
        c, s = abs(math.cos(self.angle)), abs(math.sin(self.angle))
        w = self.width * c + self.height * s
        h = self.width * s + self.height * c
        return Rect.from_center(self.cx, self.cy, w, h)


@dataclass(frozen=True)
class Found:
    """One frame's result: CamShift's rotated box, the box reported for the target (the
    selection's box on the found colours), the next search window and the mean back-projection."""

    oriented: OrientedBox
    box: Rect
    window: Rect
    density: float

    def blob(self) -> Blob:
        cx, cy = self.box.center
        return Blob(
            cx,
            cy,
            self.box,
            self.box.area,
            max(round(self.box.area), 1),
            min(self.density, 1.0),
            angle=self.oriented.angle,
            oriented_size=(self.oriented.width, self.oriented.height),
        )


def sv_mask(hsv: np.ndarray, config: CamShiftConfig) -> np.ndarray:
    """255 where S >= s_min and v_min <= V <= v_max (the thesis's sliders)."""
    low = (0, config.s_min, min(config.v_min, 255))
    high = (HUE_RANGE, 255, min(config.v_max, 255))
    return cv2.inRange(hsv, np.array(low, np.uint8), np.array(high, np.uint8))


def _channels(config: CamShiftConfig) -> tuple[list[int], list[int], list[int]]:
    """calcHist's channels, bins and ranges: hue, or hue and saturation."""
    if config.saturation_bins:
        return [0, 1], [config.hue_bins, config.saturation_bins], [0, HUE_RANGE, 0, 256]
    return [0], [config.hue_bins], [0, HUE_RANGE]


def back_projection(hsv: np.ndarray, histogram: np.ndarray, config: CamShiftConfig) -> np.ndarray:
    """(H, W) uint8: the histogram back-projected and ANDed with the S/V mask."""
    channels, _, ranges = _channels(config)
    prob = cv2.calcBackProject([np.ascontiguousarray(hsv)], channels, histogram, ranges, 1)
    return cv2.bitwise_and(prob, sv_mask(hsv, config))


def colour_histogram(hsv: np.ndarray, mask: np.ndarray, config: CamShiftConfig) -> np.ndarray:
    """Pixel counts of the masked pixels per hue (x saturation) bin, float32."""
    channels, bins, ranges = _channels(config)
    return cv2.calcHist([np.ascontiguousarray(hsv)], channels, mask, bins, ranges)


def colour_distribution(hsv: np.ndarray, config: CamShiftConfig) -> np.ndarray | None:
    """The plain colour histogram of the S/V-masked pixels, summing to 1; None with none."""
    counts = colour_histogram(hsv, sv_mask(hsv, config), config)
    total = float(counts.sum())
    return counts / total if total > 0 else None


def bhattacharyya(p: np.ndarray, q: np.ndarray) -> float:
    """sum sqrt(p q) of two distributions: 1 for equal ones, 0 for disjoint ones."""
    return float(np.sqrt(p * q).sum())


def selection_contrast(prob: np.ndarray, box: tuple[int, int, int, int]) -> float:
    """Mean of `prob` inside `box` (x, y, w, h) over its mean in the rest of the image (inf when
    the rest is dark or empty)."""
    x, y, w, h = box
    inside = prob[y : y + h, x : x + w]
    rest_pixels = prob.size - inside.size
    rest = (float(prob.sum(dtype=np.float64)) - float(inside.sum(dtype=np.float64))) / max(
        rest_pixels, 1
    )
    mean_inside = float(inside.mean()) if inside.size else 0.0
    return mean_inside / rest if rest > 0 else math.inf


def colour_spread(prob: np.ndarray) -> tuple[float, float, float, float] | None:
    """Centroid and 4-sigma extent (cx, cy, ex, ey) of a back-projection, px; None if empty
    or flat along an axis."""
    m = cv2.moments(prob)
    if m["m00"] <= 0:
        return None
    cx, cy = m["m10"] / m["m00"], m["m01"] / m["m00"]
    ex, ey = (4.0 * math.sqrt(max(m[k] / m["m00"], 0.0)) for k in ("mu20", "mu02"))
    if ex < 1.0 or ey < 1.0:
        return None
    return cx, cy, ex, ey


def _clip(box: tuple[int, int, int, int], width: int, height: int) -> tuple[int, int, int, int]:
    """An integer x, y, w, h box clipped to the image (w or h may become 0)."""
    x0, y0 = max(box[0], 0), max(box[1], 0)
    x1, y1 = min(box[0] + box[2], width), min(box[1] + box[3], height)
    return x0, y0, max(x1 - x0, 0), max(y1 - y0, 0)


def _round(box: Rect) -> tuple[int, int, int, int]:
    return round(box.x), round(box.y), max(round(box.width), 1), max(round(box.height), 1)


@dataclass(frozen=True, eq=False)
class Selection:
    """The selected region's HSV pixels with their surroundings."""

    context: np.ndarray  # (H, W, 3) HSV of the region grown by background_margin
    box: tuple[int, int, int, int]  # the region inside `context`, x, y, w, h

    @property
    def inner(self) -> np.ndarray:
        x, y, w, h = self.box
        return self.context[y : y + h, x : x + w]


class CamShiftTracker:
    """A `detector.SeededDetector`: one colour target, started from a rectangle."""

    estimates_ego_motion = False  # it follows the target in scene coordinates from known poses

    def __init__(self, config: CamShiftConfig | None = None) -> None:
        self.config = config or CamShiftConfig()
        check_config(self.config)
        self.model: ColourModel | None = None
        self.selection: Rect | None = None  # scene px, where tracking (re)starts on reset()
        self._selection: Selection | None = None  # to rebuild the model on reconfigure
        self.window: Rect | None = None  # scene px, where the next search starts
        self.last_box: Rect | None = None  # scene px, the box last reported
        self.misses = 0
        self._guide: tuple[float, float] | None = None
        self._last_stamp: int | None = None

    # --- state --------------------------------------------------------------------------------

    @property
    def tracking(self) -> bool:
        """A model exists and the target is not lost."""
        return self.model is not None and self.misses < self.config.lost_after

    def select_region(self, region: Rect, frame: CameraFrame) -> str | None:
        """Learn the colours of `region` (scene px) in `frame`; None, or why it cannot."""
        if not (region.width > 0 and region.height > 0):
            return f"the region must have a positive size, got {region}"
        view = frame.view or View.identity(*frame.size)
        inner = _clip(_round(view.rect_to_image(region)), *frame.size)
        if inner[2] < 2 or inner[3] < 2:
            return f"the region {region} lies outside the camera view {view.rect}"
        m = self.config.background_margin
        x, y, w, h = inner
        outer = _clip(
            _round(Rect(x - m * w, y - m * h, (1 + 2 * m) * w, (1 + 2 * m) * h)), *frame.size
        )
        ox, oy, ow, oh = outer
        context = np.ascontiguousarray(frame.bgr[oy : oy + oh, ox : ox + ow])
        selection = Selection(cv2.cvtColor(context, cv2.COLOR_BGR2HSV), (x - ox, y - oy, w, h))
        model = self._model(selection, (region.width, region.height))
        if isinstance(model, str):
            return model
        self.model, self._selection = model, selection
        self.selection = self.window = self.last_box = view.rect_to_scene(x, y, w, h)
        self.misses, self._guide = 0, None
        return None

    def _model(self, selection: Selection, size: tuple[float, float]) -> ColourModel | str:
        config = self.config
        inner = selection.inner
        mask = sv_mask(inner, config)
        count = int(np.count_nonzero(mask))
        if count < config.min_model_pixels:
            return (
                f"only {count} pixels of the region have saturation >= {config.s_min} and "
                f"value in [{config.v_min}, {config.v_max}] (need {config.min_model_pixels}): "
                "CamShift needs a coloured target"
            )
        histogram = colour_histogram(inner, mask, config)
        if config.background_weighting:
            around = sv_mask(selection.context, config)
            x, y, w, h = selection.box
            around[y : y + h, x : x + w] = 0
            histogram *= background_weights(colour_histogram(selection.context, around, config))
        if histogram.max() <= 0:
            return "the region's colours are all in its surroundings too"
        cv2.normalize(histogram, histogram, 0, 255, cv2.NORM_MINMAX)
        contrast = selection_contrast(
            back_projection(selection.context, histogram, config), selection.box
        )
        if contrast < config.min_contrast:
            return (
                f"its colours do not stand out from its surroundings (contrast {contrast:.1f} < "
                f"min_contrast {config.min_contrast}): CamShift would slide off it"
            )
        prob = back_projection(inner, histogram, config)
        spread = colour_spread(prob)
        if spread is None:
            return "the region's own colours cover too few of its pixels"
        cx, cy, ex, ey = spread
        w, h = inner.shape[1], inner.shape[0]
        calibration = BoxCalibration(((w / 2 - cx) / ex, (h / 2 - cy) / ey), (w / ex, h / ey))
        reference = colour_histogram(inner, mask, config) / count
        return ColourModel(histogram, float(prob.mean()) / 255.0, size, calibration, reference)

    def hand_over(self, region: Rect, frame: CameraFrame) -> str | None:
        """Offered `region` (scene px) of `frame` by another tracker (the motion tracker's measured
        target): taken when not tracking; while tracking, only when it lies apart from the tracked
        box and its colours match the model at least `rehandover_similarity` and better than the
        tracked box's colours in this frame do (CamShift drifted onto a like-coloured thing, e.g.
        a bin the person stood beside). None when taken, else why not."""
        if not self.tracking or self.model is None or self.last_box is None:
            return self.select_region(region, frame)
        threshold = self.config.rehandover_similarity
        if threshold <= 0:
            return "tracking (rehandover_similarity 0: never re-handed)"
        if region.iou(self.last_box) >= SAME_TARGET_IOU:
            return "it is the tracked target"
        offered = self.similarity(region, frame)
        if offered < threshold:
            return f"its colours match the model {offered:.2f} < {threshold}"
        tracked = self.similarity(self.last_box, frame)
        if offered <= tracked:
            return f"the tracked box matches the model better ({tracked:.2f} >= {offered:.2f})"
        return self.select_region(region, frame)

    def similarity(self, region: Rect, frame: CameraFrame) -> float:
        """Bhattacharyya coefficient of `region`'s colours in `frame` with the model's (0 when
        the region has no coloured pixel in view)."""
        if self.model is None:
            return 0.0
        view = frame.view or View.identity(*frame.size)
        x, y, w, h = _clip(_round(view.rect_to_image(region)), *frame.size)
        if w < 1 or h < 1:
            return 0.0
        patch = np.ascontiguousarray(frame.bgr[y : y + h, x : x + w])
        found = colour_distribution(cv2.cvtColor(patch, cv2.COLOR_BGR2HSV), self.config)
        return 0.0 if found is None else bhattacharyya(found, self.model.reference)

    def guide(self, centre: tuple[float, float]) -> None:
        """Start the next search with the window centred at `centre` (scene px), e.g. a filter's
        prediction; ignored when not finite."""
        if all(math.isfinite(v) for v in centre):
            self._guide = (float(centre[0]), float(centre[1]))

    def reset(self) -> None:
        """A new replay epoch: back to the selected rectangle, keeping the colour model."""
        self.window, self.misses = self.selection, 0
        self.last_box = self.selection
        self._guide = self._last_stamp = None

    def reconfigure(self, config: CamShiftConfig) -> None:
        """New parameters; the model is rebuilt from the stored selection (dropped if it no
        longer has enough coloured pixels)."""
        check_config(config)
        self.config = config
        if self._selection is not None and self.selection is not None:
            size = (self.selection.width, self.selection.height)
            model = self._model(self._selection, size)
            self.model = None if isinstance(model, str) else model

    # --- per frame ----------------------------------------------------------------------------

    def process(self, frame: CameraFrame) -> Detection:
        if self._last_stamp is not None and frame.stamp_ns <= self._last_stamp:
            raise StaleFrameError(f"stamp {frame.stamp_ns} ns is not newer than the last")
        if frame.image.ndim != 3:
            raise ValueError("CamShift needs a colour (BGR) image, got a grey one")
        self._last_stamp = frame.stamp_ns
        view = frame.view or View.identity(*frame.size)
        guide, self._guide = self._guide, None
        if self.model is None or self.window is None:
            return Detection(frame.stamp_ns, view, [], False, False)
        window = self.window
        if guide is not None:
            window = Rect.from_center(*guide, window.width, window.height)
        if self.tracking:
            found, searched = self._track(frame, view, window, self.model)
        else:
            found, searched = self._reacquire(frame, view, self.model)
        if found is None:
            self.misses += 1
            self.window = window
            return Detection(frame.stamp_ns, view, [], False, True, searched)
        self.misses, self.window, self.last_box = 0, found.window, found.box
        return Detection(frame.stamp_ns, view, [found.blob()], True, True, searched)

    def _search_region(
        self, frame: CameraFrame, view: View, window: Rect
    ) -> tuple[int, int, int, int]:
        m = self.config.search_margin
        grown = Rect(
            window.x - m * window.width,
            window.y - m * window.height,
            (1 + 2 * m) * window.width,
            (1 + 2 * m) * window.height,
        )
        return _clip(_round(view.rect_to_image(grown)), *frame.size)

    def _track(
        self, frame: CameraFrame, view: View, window: Rect, model: ColourModel
    ) -> tuple[Found | None, float]:
        """CamShift from `window` inside its search region."""
        rx, ry, rw, rh = self._search_region(frame, view, window)
        searched = rw * rh * view.scale_x * view.scale_y
        if rw < 2 or rh < 2:
            return None, searched  # the window left the view
        prob = self._back_projection(frame, (rx, ry, rw, rh), model)
        x, y, w, h = _round(view.rect_to_image(window))
        start = _clip((x - rx, y - ry, w, h), rw, rh)
        if start[2] < 1 or start[3] < 1:
            return None, searched
        return self._camshift(frame, prob, start, (rx, ry), model), searched

    def _reacquire(
        self, frame: CameraFrame, view: View, model: ColourModel
    ) -> tuple[Found | None, float]:
        """Restart CamShift at the selection-sized region of highest back-projection density."""
        width, height = frame.size
        prob = self._back_projection(frame, (0, 0, width, height), model)
        w = min(max(round(model.size[0] / view.scale_x), 1), width)
        h = min(max(round(model.size[1] / view.scale_y), 1), height)
        density = cv2.boxFilter(prob, cv2.CV_32F, (w, h), borderType=cv2.BORDER_CONSTANT)
        _, peak, _, (u, v) = cv2.minMaxLoc(density)
        searched = width * height * view.scale_x * view.scale_y
        if peak / 255.0 < self.config.min_density_ratio * model.density:
            return None, searched
        start = _clip((u - w // 2, v - h // 2, w, h), width, height)
        return self._camshift(frame, prob, start, (0, 0), model), searched

    def _back_projection(
        self, frame: CameraFrame, region: tuple[int, int, int, int], model: ColourModel
    ) -> np.ndarray:
        x, y, w, h = region
        bgr = np.ascontiguousarray(frame.bgr[y : y + h, x : x + w])
        return back_projection(cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV), model.histogram, self.config)

    def _camshift(
        self,
        frame: CameraFrame,
        prob: np.ndarray,
        start: tuple[int, int, int, int],
        offset: tuple[int, int],
        model: ColourModel,
    ) -> Found | None:
        """cv2.CamShift on `prob` (image px of `frame` from `offset`); None when the result is a
        miss."""
        view = frame.view or View.identity(*frame.size)
        criteria = (
            cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT,
            self.config.max_iterations,
            self.config.epsilon,
        )
        rotated, next_window = cv2.CamShift(prob, start, criteria)
        (cx, cy), (bw, bh), angle_deg = rotated
        nx, ny, nw, nh = next_window
        if bw < 2 or bh < 2 or nw < 1 or nh < 1:
            return None  # empty back-projection: OpenCV's (0, 0) window
        inside = prob[ny : ny + nh, nx : nx + nw]
        density = float(inside.mean()) / 255.0
        spread = colour_spread(inside)
        if spread is None or density < self.config.min_density_ratio * model.density:
            return None
        bx, by, bw_, bh_ = model.calibration.box(spread)
        left, top = nx + offset[0] + bx - bw_ / 2, ny + offset[1] + by - bh_ / 2
        reported = view.rect_to_scene(left, top, bw_, bh_)
        growth = math.sqrt(reported.area / (model.size[0] * model.size[1]))
        if growth > self.config.max_size_ratio:
            return None  # spread over a background of the target's colour
        if self.config.min_similarity > 0 and (
            self.similarity(reported, frame) < self.config.min_similarity
        ):
            return None  # slid onto something of a like colour that is not the target
        oriented = self._oriented_to_scene(view, cx + offset[0], cy + offset[1], bw, bh, angle_deg)
        window = view.rect_to_scene(nx + offset[0], ny + offset[1], nw, nh)
        return Found(oriented, reported, window, density)

    @staticmethod
    def _oriented_to_scene(
        view: View, cx: float, cy: float, width: float, height: float, angle_deg: float
    ) -> OrientedBox:
        """Image-px rotated rect -> scene (exact for equal x/y scales, else the nearest box)."""
        angle = math.radians(angle_deg)
        c, s = math.cos(angle), math.sin(angle)
        along = math.hypot(width * c * view.scale_x, width * s * view.scale_y)
        across = math.hypot(-height * s * view.scale_x, height * c * view.scale_y)
        scene_angle = math.atan2(s * view.scale_y, c * view.scale_x)
        x, y = view.to_scene(cx, cy)
        return OrientedBox(x, y, along, across, scene_angle)


METHOD: Method[CamShiftTracker] = Method.of(
    name="camshift",
    description="CamShift colour tracking of one target started from a rectangle "
    "(select_region) or handed over from a tracked target; prediction-guided search, "
    "loss and re-acquisition (seed 001)",
    config=CamShiftConfig,
    make=CamShiftTracker,
)
