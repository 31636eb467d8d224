"""CamShift colour tracking (seed 001, Bradski 1998) on a moving pan-tilt view (no rclpy).

The thesis pipeline, per frame: BGR -> HSV; the hue histogram of the selected rectangle (32 bins
over [0, 180), only pixels whose S >= s_min and v_min <= V <= v_max) normalised to max 255 is
back-projected, ANDed with the same S/V mask, and `cv2.CamShift` climbs it from the previous
window (at most `max_iterations` mean-shift steps or a shift below `epsilon` px). The result is a
rotated box (centre, size, angle) and its score.

Beyond the thesis:
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
from tracker_msgs_py.params import check_config

HUE_RANGE = 180  # OpenCV's 8-bit hue convention: [0, 180)


@dataclass(frozen=True)
class CamShiftConfig:
    """Parameters; the defaults are the thesis's (OpenCV camshiftdemo) where it gives them."""

    hue_bins: int = 32
    v_min: int = 10
    v_max: int = 256
    s_min: int = 30
    max_iterations: int = 10  # mean-shift steps per frame (OpenCV sample)
    epsilon: float = 1.0  # px, mean shift stops when the window moves less
    search_margin: float = 1.0  # search region: the window grown by this x its size on each side
    min_density_ratio: float = 0.3  # found box's mean back-projection / the model's, else a miss
    lost_after: int = 5  # consecutive misses after which the whole image is searched
    max_size_ratio: float = 4.0  # a window growing beyond this x the selected side is a miss
    min_model_pixels: int = 20  # pixels of the selection passing the S/V mask

    def problems(self) -> list[str]:
        """What is wrong with these values (empty when usable)."""
        checks = {
            "hue_bins must be in [2, 180]": 2 <= self.hue_bins <= HUE_RANGE,
            "v_min must not exceed v_max": 0 <= self.v_min <= self.v_max,
            "s_min must be in [0, 255]": 0 <= self.s_min <= 255,
            "max_iterations must be >= 1": self.max_iterations >= 1,
            "epsilon must be > 0": self.epsilon > 0,
            "search_margin must be >= 0": self.search_margin >= 0,
            "min_density_ratio must be in [0, 1]": 0 <= self.min_density_ratio <= 1,
            "lost_after must be >= 1": self.lost_after >= 1,
            "max_size_ratio must be > 1": self.max_size_ratio > 1,
            "min_model_pixels must be >= 1": self.min_model_pixels >= 1,
        }
        return [message for message, ok in checks.items() if not ok]


@dataclass(frozen=True)
class ColourModel:
    """The target's hue histogram (normalised to max 255) and its density in the selection."""

    histogram: np.ndarray  # (hue_bins, 1) float32
    density: float  # mean back-projection / 255 over the selected region
    size: tuple[float, float]  # selected width, height [scene px]


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


def sv_mask(hsv: np.ndarray, config: CamShiftConfig) -> np.ndarray:
    """255 where S >= s_min and v_min <= V <= v_max (the thesis's sliders)."""
    low = (0, config.s_min, min(config.v_min, 255))
    high = (HUE_RANGE, 255, min(config.v_max, 255))
    return cv2.inRange(hsv, np.array(low, np.uint8), np.array(high, np.uint8))


def back_projection(hsv: np.ndarray, histogram: np.ndarray, config: CamShiftConfig) -> np.ndarray:
    """(H, W) uint8: the hue histogram back-projected and ANDed with the S/V mask."""
    hue = np.ascontiguousarray(hsv[:, :, 0])
    prob = cv2.calcBackProject([hue], [0], histogram, [0, HUE_RANGE], 1)
    return cv2.bitwise_and(prob, sv_mask(hsv, config))


def hue_histogram(hsv: np.ndarray, config: CamShiftConfig) -> tuple[np.ndarray, int]:
    """The masked hue histogram of `hsv`, normalised to max 255, and how many pixels built it."""
    mask = sv_mask(hsv, config)
    count = int(np.count_nonzero(mask))
    hist = cv2.calcHist(
        [np.ascontiguousarray(hsv[:, :, 0])], [0], mask, [config.hue_bins], [0, HUE_RANGE]
    )
    cv2.normalize(hist, hist, 0, 255, cv2.NORM_MINMAX)
    return hist, count


def _clip(box: tuple[int, int, int, int], width: int, height: int) -> tuple[int, int, int, int]:
    """An integer x, y, w, h box clipped to the image (w or h may become 0)."""
    x0, y0 = max(box[0], 0), max(box[1], 0)
    x1, y1 = min(box[0] + box[2], width), min(box[1] + box[3], height)
    return x0, y0, max(x1 - x0, 0), max(y1 - y0, 0)


def _to_image(view: View, rect: Rect) -> tuple[float, float, float, float]:
    """A scene rectangle as image px x, y, w, h."""
    return (
        (rect.x - view.rect.x) / view.scale_x,
        (rect.y - view.rect.y) / view.scale_y,
        rect.width / view.scale_x,
        rect.height / view.scale_y,
    )


def _round(box: tuple[float, float, float, float]) -> tuple[int, int, int, int]:
    x, y, w, h = box
    return round(x), round(y), max(round(w), 1), max(round(h), 1)


class CamShiftTracker:
    """A `detector.SeededDetector`: one colour target, started from a rectangle."""

    estimates_ego_motion = False  # it follows the target in scene coordinates from known poses

    def __init__(self, config: CamShiftConfig | None = None) -> None:
        self.config = config or CamShiftConfig()
        check_config(self.config)
        self.model: ColourModel | None = None
        self.selection: Rect | None = None  # scene px, where tracking (re)starts on reset()
        self._selection_hsv: np.ndarray | None = None  # to rebuild the model on reconfigure
        self.window: Rect | None = None  # scene px, where the next search starts
        self.misses = 0
        self._guide: tuple[float, float] | None = None
        self._last_stamp: int | None = None

    # --- state --------------------------------------------------------------------------------

    @property
    def tracking(self) -> bool:
        """A model exists and the target is not lost."""
        return self.model is not None and self.misses < self.config.lost_after

    def select_region(self, region: Rect, frame: CameraFrame) -> str | None:
        """Learn the hue histogram of `region` (scene px) in `frame`; None, or why it cannot."""
        if not (region.width > 0 and region.height > 0):
            return f"the region must have a positive size, got {region}"
        view = frame.view or View.identity(*frame.size)
        x, y, w, h = _clip(_round(_to_image(view, region)), *frame.size)
        if w < 2 or h < 2:
            return f"the region {region} lies outside the camera view {view.rect}"
        hsv = cv2.cvtColor(np.ascontiguousarray(frame.bgr[y : y + h, x : x + w]), cv2.COLOR_BGR2HSV)
        model = self._model(hsv, view.rect_to_scene(x, y, w, h))
        if isinstance(model, str):
            return model
        self.model, self._selection_hsv = model, hsv
        self.selection = self.window = view.rect_to_scene(x, y, w, h)
        self.misses, self._guide = 0, None
        return None

    def _model(self, hsv: np.ndarray, region: Rect) -> ColourModel | str:
        histogram, count = hue_histogram(hsv, self.config)
        if count < self.config.min_model_pixels:
            return (
                f"only {count} pixels of the region have saturation >= {self.config.s_min} and "
                f"value in [{self.config.v_min}, {self.config.v_max}] (need "
                f"{self.config.min_model_pixels}): CamShift needs a coloured target"
            )
        density = float(back_projection(hsv, histogram, self.config).mean()) / 255.0
        return ColourModel(histogram, density, (region.width, region.height))

    def guide(self, centre: tuple[float, float]) -> None:
        """Start the next search with the window centred at `centre` (scene px), e.g. a filter's
        prediction; ignored when not finite."""
        if all(math.isfinite(v) for v in centre):
            self._guide = (float(centre[0]), float(centre[1]))

    def reset(self) -> None:
        """A new replay epoch: back to the selected rectangle, keeping the colour model."""
        self.window, self.misses = self.selection, 0
        self._guide = self._last_stamp = None

    def reconfigure(self, config: CamShiftConfig) -> None:
        """New parameters; the model is rebuilt from the stored selection (dropped if it no
        longer has enough coloured pixels)."""
        check_config(config)
        self.config = config
        if self._selection_hsv is not None and self.selection is not None:
            model = self._model(self._selection_hsv, self.selection)
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
        box, next_window, density = found
        self.misses, self.window = 0, next_window
        return Detection(frame.stamp_ns, view, [self._blob(box, density)], True, True, searched)

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
        return _clip(_round(_to_image(view, grown)), *frame.size)

    def _track(
        self, frame: CameraFrame, view: View, window: Rect, model: ColourModel
    ) -> tuple[tuple[OrientedBox, Rect, float] | None, float]:
        """CamShift from `window` inside its search region."""
        rx, ry, rw, rh = self._search_region(frame, view, window)
        searched = rw * rh * view.scale_x * view.scale_y
        if rw < 2 or rh < 2:
            return None, searched  # the window left the view
        prob = self._back_projection(frame, (rx, ry, rw, rh), model)
        x, y, w, h = _round(_to_image(view, window))
        start = _clip((x - rx, y - ry, w, h), rw, rh)
        if start[2] < 1 or start[3] < 1:
            return None, searched
        return self._camshift(prob, start, (rx, ry), view, model), searched

    def _reacquire(
        self, frame: CameraFrame, view: View, model: ColourModel
    ) -> tuple[tuple[OrientedBox, Rect, float] | None, float]:
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
        return self._camshift(prob, start, (0, 0), view, model), searched

    def _back_projection(
        self, frame: CameraFrame, region: tuple[int, int, int, int], model: ColourModel
    ) -> np.ndarray:
        x, y, w, h = region
        bgr = np.ascontiguousarray(frame.bgr[y : y + h, x : x + w])
        return back_projection(cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV), model.histogram, self.config)

    def _camshift(
        self,
        prob: np.ndarray,
        start: tuple[int, int, int, int],
        offset: tuple[int, int],
        view: View,
        model: ColourModel,
    ) -> tuple[OrientedBox, Rect, float] | None:
        """cv2.CamShift on `prob` (image px from `offset`); None when the result is a miss."""
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
        density = float(prob[ny : ny + nh, nx : nx + nw].mean()) / 255.0
        if density < self.config.min_density_ratio * model.density:
            return None
        box = self._oriented_to_scene(view, cx + offset[0], cy + offset[1], bw, bh, angle_deg)
        side = math.sqrt(model.size[0] * model.size[1])
        if math.sqrt(box.width * box.height) > self.config.max_size_ratio * side:
            return None  # spread over a background of the target's colour
        window = view.rect_to_scene(nx + offset[0], ny + offset[1], nw, nh)
        return box, window, density

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

    @staticmethod
    def _blob(box: OrientedBox, density: float) -> Blob:
        bounds = box.bounds
        area = box.width * box.height
        return Blob(
            box.cx,
            box.cy,
            bounds,
            area,
            max(round(area), 1),
            min(density, 1.0),
            angle=box.angle,
            oriented_size=(box.width, box.height),
        )
