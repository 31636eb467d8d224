"""MOG2 background subtraction for a static camera: seed 004's detector (no rclpy).

Seed 004 (`../shared/seeds/004-gmphd-occlusion.md` §1) detects many small objects (10-30 px)
in a static camera's video: optional histogram equalisation, a Gaussian-mixture background model
(Stauffer-Grimson; OpenCV's MOG2 stands in), the morphology the thesis's genetic algorithm chose
-- dilate with a radius-4 diamond, then close with a 2x2 rectangle -- and one blob per connected
component, whose centroid and box the GM-PHD tracker takes as measurements. Per frame:

1. the image MOG2 models: the colour image (`colour`; a grey frame is replicated) or the grey
   one, histogram-equalised with `equalize` (each channel of a colour image): the model is then
   blind to a global brightness or contrast change, but equalisation also multiplies the sensor
   noise by its slope (about 4 on a low-contrast ground), beyond what MOG2's variance follows;
2. `cv2.BackgroundSubtractorMOG2.apply` with `history`, `var_threshold` and `learning_rate`
   (negative: OpenCV's automatic 1 / min(2 n, history)); with `detect_shadows` its shadow pixels
   (127) are background. On a grey image MOG2's shadow test reduces to "darkened to 50-100 % of
   the background", which also swallows objects darker than the ground -- hence `colour`;
3. the morphology: dilate with the diamond of radius `dilate_radius` (|dx| + |dy| <= r; 0: none),
   then close with a `close_size` square (1: none). The close is shift-free: OpenCV's MORPH_CLOSE
   with an even element moves the mask by a pixel, MATLAB's imclose (the thesis) does not;
4. blobs: 8-connected components of at least `min_blob_area` scene px^2, largest first, mapped to
   the scene through the frame's view like the other detectors (`motion.find_blobs`); `score` =
   the share of the blob's pixels MOG2 itself called foreground (the rest the morphology added).

The model is a static camera's: the first `warmup_frames` frames after a (re)start are learned,
not compared, and a frame whose view moved or zoomed (any edge of its scene rectangle beyond
`VIEW_TOLERANCE` image px of the previous one) or whose size changed restarts the model
(`Detection.history_reset`) instead of reporting the whole image as foreground.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from tracker_detect import blobs
from tracker_detect.blobs import find_blobs, presence_test
from tracker_detect.detector import CameraFrame, Detection, checked_view
from tracker_detect.registration import View
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

#: MOG2's label of a foreground pixel (shadows are 127, `getShadowValue()`; background 0).
FOREGROUND_VALUE = 255
#: A view whose scene rectangle's edges all stay within this many image px of the previous one's
#: is the same view (rounding of a reported window); beyond it the model restarts.
VIEW_TOLERANCE = 0.5
#: Blob pixel connectivity (the thesis's bwlabel / regionprops default).
CONNECTIVITY = 8
#: Parameters that change the images the model learns: a change restarts it.
MODEL_INPUT_PARAMETERS = ("equalize", "colour")


@dataclass(frozen=True)
class Mog2Config:
    """Parameters of `Mog2Detector` (defaults: seed 004 with OpenCV's MOG2 defaults)."""

    equalize: bool = param(
        False, "histogram-equalise the image first (the grey image, or each colour channel)"
    )
    colour: bool = param(
        True,
        "model the colour image (a grey one replicated); false: the grey image, as the thesis "
        "(MOG2's shadow test then takes any pixel darkened to 50-100 % for a shadow)",
    )
    history: int = param(500, "frames of MOG2's history (OpenCV: 500)", min=1, max=100000)
    var_threshold: float = param(
        16.0,
        "squared Mahalanobis distance within which a pixel matches a background mode (OpenCV: 16)",
        min=0.01,
        max=10000.0,
    )
    detect_shadows: bool = param(True, "MOG2's shadow pixels are background, not objects")
    learning_rate: float = param(
        -1.0,
        "model learning rate per frame (negative: OpenCV's automatic 1 / min(2 n, history))",
        min=-1.0,
        max=1.0,
    )
    dilate_radius: int = param(
        4,
        "radius of the diamond the mask is dilated with (seed: 4; 0: none)",
        min=0,
        max=50,
        unit="px",
    )
    close_size: int = param(
        2,
        "side of the square the dilated mask is closed with (seed: 2; 1: none)",
        min=1,
        max=51,
        unit="px",
    )
    min_blob_area: float = blobs.min_blob_area(50.0)  # a lone pixel dilates to 41 px
    warmup_frames: int = param(
        5,
        "frames after a (re)start of the model that are learned, not compared (a new model's "
        "first frame is all foreground)",
        min=1,
        max=100000,
    )
    presence_fraction: float = blobs.presence_fraction(0.0)  # 0: any blob is a measurement

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this config is unusable beyond its fields' own ranges (empty when it is fine)."""
        return []


def diamond(radius: int) -> np.ndarray:
    """The (2r + 1)^2 diamond structuring element, 1 where |dx| + |dy| <= r (MATLAB's
    strel('diamond', r))."""
    if radius < 0:
        raise ValueError(f"diamond radius must be >= 0, got {radius}")
    offsets = np.abs(np.arange(-radius, radius + 1))
    element: np.ndarray = (offsets[:, None] + offsets[None, :] <= radius).astype(np.uint8)
    return element


def close_square(mask: np.ndarray, size: int) -> np.ndarray:
    """Morphological closing with a size x size square, without a shift for even sizes.

    cv2.dilate and cv2.erode both place an even element's anchor at size // 2, so their
    composition (MORPH_CLOSE) moves the mask; the erosion here uses the reflected anchor, which
    makes it MATLAB's imclose: extensive, idempotent, in place.
    """
    if size <= 1:
        return mask
    element = np.ones((size, size), np.uint8)
    reflected = size - 1 - size // 2
    dilated = cv2.dilate(mask, element)
    closed: np.ndarray = cv2.erode(dilated, element, anchor=(reflected, reflected))
    return closed


class Mog2Detector:
    """`detector.Detector`: MOG2 background subtraction with seed 004's morphology (module doc).

    Without a pose (view None) the image is the scene (`View.identity`), as for the other
    detectors.
    """

    estimates_ego_motion = False

    def __init__(self, config: Mog2Config | None = None) -> None:
        self.config = config or Mog2Config()
        self._dilate = diamond(self.config.dilate_radius)
        self._model: cv2.BackgroundSubtractorMOG2 | None = None
        self._frames = 0  # frames the current model has learned
        self._view: View | None = None  # the view of the current model
        self._last_stamp: int | None = None

    @property
    def frames_learned(self) -> int:
        """Frames the current model has seen since it (re)started."""
        return self._frames

    def reset(self) -> None:
        """Forget the model and the stamps."""
        self._restart()
        self._view = None
        self._last_stamp = None

    def reconfigure(self, config: Mog2Config) -> None:
        """Use `config` from the next frame on. History, variance threshold and shadow detection
        are set on the live model; a changed `equalize` or `colour` restarts it (it learned other
        images); the clean-up and blob parameters need nothing."""
        old, self.config = self.config, config
        self._dilate = diamond(config.dilate_radius)
        if any(getattr(old, n) != getattr(config, n) for n in MODEL_INPUT_PARAMETERS):
            self._restart()
        elif self._model is not None:
            self._model.setHistory(config.history)
            self._model.setVarThreshold(config.var_threshold)
            self._model.setDetectShadows(config.detect_shadows)

    def process(self, frame: CameraFrame) -> Detection:
        """Detect in `frame`; raises StaleFrameError or ValueError with the state untouched."""
        c = self.config
        image = frame.image
        if image.dtype != np.uint8 or image.size == 0 or image.ndim not in (2, 3):
            raise ValueError(f"expected a grey or BGR uint8 image, got {image.dtype} {image.shape}")
        if image.ndim == 3 and image.shape[2] != 3:
            raise ValueError(f"expected a grey or BGR uint8 image, got shape {image.shape}")
        width, height = frame.size
        view = checked_view(frame, self._last_stamp)
        history_reset = self._view is not None and not same_view(self._view, view)
        if history_reset or self._model is None:
            self._restart()
        self._last_stamp, self._view = frame.stamp_ns, view
        assert self._model is not None
        labels = self._model.apply(self._model_input(frame), learningRate=c.learning_rate)
        self._frames += 1
        if self._frames <= c.warmup_frames:
            return Detection(frame.stamp_ns, view, [], False, False, history_reset=history_reset)
        foreground = (labels == FOREGROUND_VALUE).astype(np.uint8)  # shadows are background
        mask = self._clean(foreground)
        blobs = [
            b
            for b in find_blobs(mask, foreground.astype(np.float32), view, CONNECTIVITY)
            if b.area >= c.min_blob_area
        ]
        compared = width * height
        present = presence_test(sum(b.pixel_count for b in blobs), compared, c.presence_fraction)
        return Detection(
            frame.stamp_ns,
            view,
            blobs,
            present,
            True,
            compared_area=compared * view.scale_x * view.scale_y,
            mask=mask,
            history_reset=history_reset,
        )

    def _restart(self) -> None:
        """A new, empty MOG2 model (the next `warmup_frames` frames are learned)."""
        c = self.config
        self._model = cv2.createBackgroundSubtractorMOG2(
            history=c.history, varThreshold=c.var_threshold, detectShadows=c.detect_shadows
        )
        self._frames = 0

    def _model_input(self, frame: CameraFrame) -> np.ndarray:
        """The image MOG2 models: BGR (grey replicated) or grey, equalised on request."""
        if not self.config.colour:
            grey = frame.gray
            return cv2.equalizeHist(grey) if self.config.equalize else grey
        bgr = np.ascontiguousarray(frame.bgr)
        if not self.config.equalize:
            return bgr
        equalised: np.ndarray = cv2.merge([cv2.equalizeHist(c) for c in cv2.split(bgr)])
        return equalised

    def _clean(self, foreground: np.ndarray) -> np.ndarray:
        """Seed 004's morphology: dilate with the diamond, then close with the square."""
        mask = foreground
        if self.config.dilate_radius > 0:
            mask = cv2.dilate(mask, self._dilate)
        return close_square(mask, self.config.close_size)


def same_view(previous: View, current: View) -> bool:
    """Whether two views show the same scene rectangle at the same image size (within
    VIEW_TOLERANCE image px on every edge)."""
    if (previous.width, previous.height) != (current.width, current.height):
        return False
    a, b = previous.rect, current.rect
    edges = (
        (b.x - a.x) / current.scale_x,
        (b.x + b.width - a.x - a.width) / current.scale_x,
        (b.y - a.y) / current.scale_y,
        (b.y + b.height - a.y - a.height) / current.scale_y,
    )
    return all(abs(e) <= VIEW_TOLERANCE for e in edges)


METHOD: Method[Mog2Detector] = Method.of(
    name="mog2",
    description="OpenCV MOG2 background subtraction for a static camera, dilate (diamond 4) "
    "+ close (2x2), 8-connected blobs of small objects (seed 004)",
    config=Mog2Config,
    make=Mog2Detector,
)
