"""SSIM against a background mosaic: detect objects, not change (no rclpy).

Seed 000 compares frame k with frame k - 3, so a blob covers where a mover was *and* where it is
(1.5-1.7x its size once dilated) and anything that flutters in place is motion. Here SSIM stays
the change measure, but the current view is compared with `mosaic.SceneMosaic`, the background
of the surveillance area kept in scene coordinates, so foreground pixels are the objects'
silhouettes:

0. with `register_reach`, the view is first aligned with the mosaic (phase correlation of the
   view against the background seen through its pose, whole px, kept only when the view then
   differs from the background clearly less than at its pose): a camera that shakes by more
   than its pose reports would otherwise see every edge of the scene as foreground; the aligned
   view is used for every step below, so boxes are where the image really looks;
1. foreground = SSIM(view, background seen through the same window) <= threshold, judged only
   where the background was observed `min_observations` times;
2. the k - gap comparison of the seed (`motion.MotionDetector`, no morphology) says which of
   those pixels are also *changing*: a mover; a foreground pixel that does not change is a ghost
   (the background learned a mover that has gone) or a stopped object;
3. pixels whose flicker rate (share of frames foreground and changing) is >= flicker_level move in
   place -- tape, leaves, flicker -- and are never foreground; with `shadow_ratio` and a colour
   image, neither are cast shadows: the background darkened (to shadow_ratio..SHADOW_MAX_RATIO
   of its brightness) with its chromaticity kept, which the mosaic learns beside the grey;
4. the mask is closed (joins a silhouette's fragments), hole-filled and shrunk by the SSIM
   window's spread across object edges (1 px), *not dilated*; blobs are its connected
   components, boxes their tight boxes; blobs flatter than `min_aspect` (height / width) are
   dropped when it is set (a person stands, a strip of barrier tape or a foot's shadow lies; a
   blob cut by the view's top or bottom edge needs half that: only a slice of it is in view);
5. the mosaic learns the view: quickly (learning_rate) where nothing is foreground, at heal_rate
   where the view differs but does not change (ghosts fade, a stopped object joins the
   background), not at all under movers; with `stopped_heal_rate` below heal_rate, a still
   blob whose outline is a clearly stronger edge in the view than in the background (a person
   who stopped; a ghost's outline is in the background, where the mover stood) heals at that
   slower rate, all of it, so someone standing still stays foreground for seconds rather than
   a few frames, and leaves no ghost when they walk on. Before foliage or posts a person's
   outline is no stronger than the background's there; the detector then asks a long-term
   background (a second mosaic that learns only where the view matches the background: the
   scene before anything stopped in it), which a stopped person still differs from and a ghost
   does not.

Steps 2 and 5 only teach the models (nothing of them reaches the frame's own blobs), so they run
after the detections are made: `learn_last_frame`, which the detector node calls once it has
published them (about a third of the detector's time out of the image-to-command latency), and
which the next `process` does first when nobody called it; the detections are the same either way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from tracker_detect import blobs
from tracker_detect.background.mosaic import MosaicSample, SceneMosaic
from tracker_detect.blobs import fill_holes, find_blobs, odd_side, presence_test
from tracker_detect.detector import CameraFrame, Detection, UnusableViewError, checked_view
from tracker_detect.motion.motion import DetectorConfig, MotionDetector, paste_map
from tracker_detect.registration import View, phase_correlation_shift
from tracker_detect.ssim import SsimParams, auto_downsample_factor, ssim_map
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

# Share of the view's height within which a blob is cut by the view's top or bottom edge (the
# judged area ends a few px inside the view: SSIM window, erosion).
EDGE_MARGIN = 0.08
# A cast shadow darkens the ground to between shadow_ratio and SHADOW_MAX_RATIO of its brightness
# and keeps its colour: chromaticity (r, g) within SHADOW_CHROMA (L1); too dark pixels have no
# reliable colour (their sum of B, G, R is below SHADOW_MIN_SUM).
SHADOW_MAX_RATIO = 0.95
SHADOW_CHROMA = 0.04
SHADOW_MIN_SUM = 60.0
# Registration: the view is aligned with the mosaic only once this share of it was judged, and
# only on a correlation peak at least this high (a view dominated by movers, or by a background
# the mosaic has not seen yet, keeps its pose).
REGISTER_JUDGED_SHARE = 0.5
REGISTER_MIN_PEAK = 0.05
REGISTER_MIN_GAIN = 0.9  # ... and the aligned view must differ from it by less than this x before
MAX_REGISTER_REACH = 64
# The background mosaic's largest size, scene px: 16.8 Mpx (a 360-degree pan at a 1000 px focal
# length and 2000 px of tilt fits; ~400 MB with colour). A view that would need more is refused.
MAX_MOSAIC_PIXELS = 2**24
# A blob is a stopped object, held at stopped_heal_rate, when at most this share of it moves and
# its outline is this many times a stronger edge in the view than in the background.
STOPPED_MOVING_SHARE = 0.25
STOPPED_EDGE_RATIO = 2.0
# ... or when it differs from the long-term background at least LASTING_SHARE as much as from
# the background (it is still there), its outline is at least LASTING_EDGE_RATIO as strong in
# the view (not clearly the background's: a ghost) and its flicker rate is at most
# LASTING_FLICKER (a piece of foliage at rest is not an object that stopped).
LASTING_SHARE = 0.6
LASTING_EDGE_RATIO = 0.8
LASTING_FLICKER = 0.15
LASTING_MIN_PX = 200  # image px: smaller blobs (a leaf at rest) are held only by the outline test


@dataclass(frozen=True)
class BackgroundConfig:
    """Parameters of `BackgroundDetector`."""

    threshold: float = param(0.5, "SSIM at or below which a pixel is foreground", min=-1.0, max=1.0)
    gap: int = param(3, "frames to the image that tells moving from still pixels", min=1, max=100)
    learning_rate: float = param(
        0.05, "background blend rate where nothing differs", min=0.0, max=1.0
    )
    heal_rate: float = param(
        0.05,
        "background blend rate where the view differs but does not change (ghosts, stopped "
        "objects)",
        min=0.0,
        max=1.0,
    )
    stopped_heal_rate: float = param(
        0.05,
        "background blend rate where the view differs but does not change, on a blob whose "
        "outline is an edge of the view and not of the background (a stopped object, not a "
        "ghost); below heal_rate it stays foreground longer",
        min=0.0,
        max=1.0,
    )
    warmup_observations: int = param(
        20, "a scene pixel's first observations are averaged", min=1, max=100000
    )
    min_observations: int = param(
        3, "a pixel is judged once the background has seen it this often", min=1, max=100000
    )
    flicker_observations: int = param(
        30, "the flicker rate is trusted once a pixel was seen this often", min=1, max=100000
    )
    flicker_memory: float = param(
        300.0, "time constant of the flicker rate", min=1.0, max=1e6, unit="frames"
    )
    flicker_level: float = param(
        0.5,
        "flicker rate (share of frames foreground and changing) from which a pixel moves in "
        "place and is ignored",
        min=0.0,
        max=1.0,
    )
    close_size: int = odd_side(5, "side of the elliptic closing element (1: none)", "close_size")
    shrink_size: int = odd_side(
        3, "side of the elliptic erosion undoing the SSIM window's spread (1: none)", "shrink_size"
    )
    connectivity: int = blobs.connectivity(8)
    min_blob_area: float = blobs.min_blob_area(60.0)
    min_aspect: float = param(
        0.0,
        "drop blobs flatter than this height / width (0: keep all; people stand, tape lies)",
        min=0.0,
        max=10.0,
    )
    shadow_ratio: float = param(
        0.0,
        "ignore cast shadows: pixels darkened to between this and 0.95 of the background's "
        "brightness that keep its colour (colour images only; 0: off)",
        min=0.0,
        max=0.94,  # below SHADOW_MAX_RATIO
    )
    register_reach: int = param(
        0,
        "align each view with the background mosaic by phase correlation, up to this far, "
        "when the camera shakes more than its pose reports (0: trust the pose)",
        min=0,
        max=MAX_REGISTER_REACH,
        unit="px",
    )
    presence_fraction: float = blobs.presence_fraction(0.0008)
    auto_downsample: bool = blobs.auto_downsample(True)
    ssim: SsimParams = field(default_factory=SsimParams)

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this config is unusable beyond its fields' own ranges (empty when it is fine)."""
        return []


@dataclass(frozen=True)
class _Lesson:
    """What one frame teaches the background models (step 5), kept until they learn it."""

    stamp_ns: int
    view: View  # the view as detected (aligned, with register_reach)
    gray: np.ndarray
    different: np.ndarray  # bool: SSIM against the background at or below the threshold
    mask: np.ndarray  # the cleaned foreground
    background: MosaicSample  # the background the view was compared with
    chroma: np.ndarray | None


class BackgroundDetector:
    """`Detector`: SSIM of each view against the scene's background mosaic (module doc).

    Without a pose (view None) the camera is taken to be static: the mosaic is then the
    background of the image itself, which is what a fixed camera needs.
    """

    estimates_ego_motion = False

    def __init__(self, config: BackgroundConfig | None = None) -> None:
        self.config = config or BackgroundConfig()
        self.mosaic = SceneMosaic(self.config.warmup_observations, self.config.flicker_memory)
        # the scene before anything stopped in it: learns only where the view is background
        self.long_term = SceneMosaic(self.config.warmup_observations, self.config.flicker_memory)
        self._change = MotionDetector(self._change_config(self.config))
        self._last_stamp: int | None = None
        self._size: tuple[int, int] | None = None
        self._lesson: _Lesson | None = None  # the last frame, until the models learn it

    @staticmethod
    def _change_config(config: BackgroundConfig) -> DetectorConfig:
        return DetectorConfig(
            gap=config.gap,
            threshold=config.threshold,
            morphology=(),
            compensation="known",
            auto_downsample=config.auto_downsample,
            ssim=config.ssim,
        )

    def reconfigure(self, config: BackgroundConfig) -> None:
        """Use `config` from the next frame on, keeping the mosaic."""
        self.learn_last_frame()  # with the config it was detected with
        self.config = config
        for mosaic in (self.mosaic, self.long_term):
            mosaic.warmup_observations = config.warmup_observations
            mosaic.flicker_memory = config.flicker_memory
        self._change.reconfigure(self._change_config(config))

    def reset(self) -> None:
        """Forget the mosaic and the frame history."""
        self.mosaic.clear()
        self.long_term.clear()
        self._change.reset()
        self._last_stamp = None
        self._size = None
        self._lesson = None

    def process(self, frame: CameraFrame) -> Detection:
        c = self.config
        gray = frame.gray
        if gray.ndim != 2 or gray.size == 0 or gray.dtype != np.uint8:
            raise ValueError(f"expected a grey uint8 (H, W) image, got {gray.dtype} {gray.shape}")
        height, width = gray.shape
        view = checked_view(frame, self._last_stamp)
        self._check_room(view)
        self.learn_last_frame()  # the frame before's step 5, when the caller left it
        history_reset = self._size is not None and self._size != (width, height)
        if history_reset and frame.view is None:
            # a static camera's mosaic is the image: a new size, a new scene
            self.mosaic.clear()
            self.long_term.clear()
        self._last_stamp, self._size = frame.stamp_ns, (width, height)
        background = self.mosaic.sample(view)
        judged = background.observations >= c.min_observations
        if c.register_reach > 0:
            grey = gray.astype(np.float32)
            shift = self._residual_shift(grey, background.mean, judged)
            if shift != (0, 0):
                moved = view.translated(*shift)
                aligned = self.mosaic.sample(moved)
                aligned_judged = aligned.observations >= c.min_observations
                if _fits_better(grey, aligned.mean, background.mean, aligned_judged & judged):
                    view, background, judged = moved, aligned, aligned_judged
        chroma = (
            _chromaticity(frame.image) if c.shadow_ratio > 0 and frame.image.ndim == 3 else None
        )
        similarity = self._similarity(gray, background.mean, judged)
        different = similarity <= c.threshold
        flickers = (background.flicker >= c.flicker_level) & (
            background.observations >= c.flicker_observations
        )
        in_place = cv2.dilate(flickers.astype(np.uint8), _ellipse(7))
        foreground = different & (in_place == 0)
        if chroma is not None and background.chroma is not None:
            foreground &= ~self._shadow(gray, chroma, background)
        mask = self._clean(foreground.astype(np.uint8))
        # copies: the caller owns the image and the Detection's mask until the models learn
        self._lesson = _Lesson(
            frame.stamp_ns, view, gray.copy(), different, mask.copy(), background, chroma
        )
        blobs = [
            b
            for b in find_blobs(mask, similarity, view, c.connectivity)
            if b.area >= c.min_blob_area and self._upright(b.bbox, view.rect)
        ]
        compared = int(np.count_nonzero(judged))
        present = presence_test(sum(b.pixel_count for b in blobs), compared, c.presence_fraction)
        return Detection(
            frame.stamp_ns,
            view,
            blobs,
            present,
            compared > 0,
            compared_area=compared * view.scale_x * view.scale_y,
            similarity=similarity,
            mask=mask,
            history_reset=history_reset,
        )

    def _check_room(self, view: View) -> None:
        """UnusableViewError when the mosaic would outgrow MAX_MOSAIC_PIXELS to hold `view` (a
        pose far off the scene, a window of absurd size)."""
        needed = self.mosaic.pixels_covering(view)
        if needed > MAX_MOSAIC_PIXELS:
            r = view.rect
            raise UnusableViewError(
                f"the view {r.width:.0f}x{r.height:.0f} at ({r.x:.0f}, {r.y:.0f}) scene px would "
                f"grow the background to {needed:.3g} px (at most {MAX_MOSAIC_PIXELS:.3g})"
            )

    def learn_last_frame(self) -> None:
        """Steps 2 and 5 (module doc) for the last frame `process`ed, if not done yet: which of
        its pixels change, and the background models learn its view. Nothing of it reaches that
        frame's detections, so a node calls it after publishing them (the detections go out ~2 ms
        sooner); `process` does it first thing otherwise. Either way every frame gives the same
        detections."""
        lesson, self._lesson = self._lesson, None
        if lesson is None:
            return
        c = self.config
        view, gray, different, background = (
            lesson.view,
            lesson.gray,
            lesson.different,
            lesson.background,
        )
        changing = self._changing(gray, lesson.stamp_ns, view)
        movers = different & changing
        heal, learn = np.float32(c.heal_rate), np.float32(c.learning_rate)
        rate = np.where(different, np.where(changing, np.float32(0.0), heal), learn)
        holds_stopped = c.stopped_heal_rate < c.heal_rate
        if holds_stopped and (different & ~changing).any():
            # the whole blob, also where its flat inside looks like the ground to SSIM (its
            # movers keep their rate 0: the minimum)
            long_term = self._long_term_view(view, gray)
            still = _stopped_objects(
                lesson.mask, movers, gray, background, long_term, c.connectivity
            )
            rate[still] = np.minimum(rate[still], np.float32(c.stopped_heal_rate))
        # The flicker rate follows whole moving regions, not single pixels: SSIM of two
        # textures is noisy pixel by pixel, a fluttering patch is moving as a region.
        moving = self._clean(movers.astype(np.uint8), shrink=False)
        chroma = lesson.chroma
        self.mosaic.update(view, gray, rate, moving, None if chroma is None else chroma[..., :2])
        if holds_stopped:
            seen = np.where(different, np.float32(0.0), learn)
            self.long_term.update(view, gray, seen, np.zeros_like(moving))

    def _long_term_view(self, view: View, gray: np.ndarray) -> np.ndarray:
        """The long-term background seen through `view`; the view itself where it has not
        been observed `min_observations` times (no evidence that anything stopped there)."""
        sample = self.long_term.sample(view)
        known = sample.observations >= self.config.min_observations
        return np.where(known, sample.mean, gray.astype(np.float32))

    def _upright(self, box: Rect, window: Rect) -> bool:
        """Whether a blob is at least `min_aspect` tall for its width; one cut by the top or
        bottom of the view (within EDGE_MARGIN of its height) needs only half that: only a slice
        of it is in view (a strip of tape is flatter still)."""
        aspect = self.config.min_aspect
        if box.height >= aspect * box.width:
            return True
        margin = EDGE_MARGIN * window.height
        cut = box.y <= window.y + margin or box.y + box.height >= window.y + window.height - margin
        return cut and box.height >= 0.5 * aspect * box.width

    def _residual_shift(
        self, grey: np.ndarray, background: np.ndarray, judged: np.ndarray
    ) -> tuple[int, int]:
        """Where the view really shows the background, relative to where its pose says, in whole
        image px: the camera shakes (wind, a mast, a vehicle) by more than the pose reports, and
        a view compared with the background a few px off makes every edge foreground. (0, 0)
        when the view cannot be aligned or the shift is beyond `register_reach`."""
        if np.count_nonzero(judged) < REGISTER_JUDGED_SHARE * judged.size:
            return (0, 0)
        seen = np.where(judged, background, grey)  # the unseen part pulls towards no shift
        try:
            shift = phase_correlation_shift(seen, grey, candidates=1)
        except ValueError:  # a view too small to correlate
            return (0, 0)
        dx, dy = round(shift.dx), round(shift.dy)
        reach = self.config.register_reach
        if shift.score < REGISTER_MIN_PEAK or max(abs(dx), abs(dy)) > reach:
            return (0, 0)
        return (dx, dy)

    def _shadow(self, gray: np.ndarray, chroma: np.ndarray, background: MosaicSample) -> np.ndarray:
        """Pixels darker than the background by a shadow's ratio, of the background's colour."""
        ratio = (gray.astype(np.float32) + 1.0) / (background.mean + 1.0)
        assert background.chroma is not None
        drift = np.abs(chroma[..., 0] - background.chroma[..., 0]) + np.abs(
            chroma[..., 1] - background.chroma[..., 1]
        )
        result: np.ndarray = (
            (ratio >= self.config.shadow_ratio)
            & (ratio <= SHADOW_MAX_RATIO)
            & (drift <= SHADOW_CHROMA)
            & (chroma[..., 2] >= SHADOW_MIN_SUM)
        )
        return result

    def _changing(self, gray: np.ndarray, stamp_ns: int, view: View) -> np.ndarray:
        """Pixels whose SSIM against frame k - gap (aligned) is at most the threshold."""
        similarity = self._change.change_map(gray, stamp_ns, view)
        if similarity is None:
            return np.zeros(gray.shape, bool)
        result: np.ndarray = similarity <= self.config.threshold
        return result

    def _similarity(
        self, gray: np.ndarray, background: np.ndarray, judged: np.ndarray
    ) -> np.ndarray:
        """SSIM map of the view against the background; ones where the background is unknown."""
        similarity = np.ones(gray.shape, np.float32)
        if not judged.any():
            return similarity
        c = self.config
        factor = auto_downsample_factor(gray.shape) if c.auto_downsample else 1
        if min(gray.shape) // factor < c.ssim.win_size + 1:
            return similarity
        local = ssim_map(gray, background, c.ssim, valid=True, downsample_factor=factor)
        height, width = gray.shape
        paste_map(similarity, local, (0, 0, width, height), c.ssim.border, factor)
        similarity[~judged] = 1.0
        return similarity

    def _clean(self, mask: np.ndarray, shrink: bool = True) -> np.ndarray:
        """Close (join fragments), fill holes, shrink by the SSIM window's spread."""
        c = self.config
        if c.close_size > 1:
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, _ellipse(c.close_size))
        mask = fill_holes(mask)
        if shrink and c.shrink_size > 1:
            mask = cv2.erode(mask, _ellipse(c.shrink_size))
        return mask


def _fits_better(
    grey: np.ndarray, aligned: np.ndarray, posed: np.ndarray, both_judged: np.ndarray
) -> bool:
    """Whether the view differs from the background at the aligned place clearly less than at
    its pose (mean absolute difference where both were judged): a correlation peak moved by a
    large mover is not taken for shake."""
    if not both_judged.any():
        return False
    there = float(cv2.absdiff(grey, aligned)[both_judged].mean())
    here = float(cv2.absdiff(grey, posed)[both_judged].mean())
    return there < REGISTER_MIN_GAIN * here


def _stopped_objects(
    mask: np.ndarray,
    moving: np.ndarray,
    gray: np.ndarray,
    background: MosaicSample,
    long_term: np.ndarray,
    connectivity: int,
) -> np.ndarray:
    """The pixels of `mask`'s blobs (grown by a px) that are still objects standing there now:
    at most STOPPED_MOVING_SHARE of the blob is `moving`, and either its outline is an edge of
    the view STOPPED_EDGE_RATIO times stronger than of the background (mean gradient magnitude
    along the blob's morphological gradient), or it is still there against the `long_term`
    background (module doc), its outline not clearly the background's and its place not one
    that flickers (the LASTING_ constants).

    Along a stopped person's outline the view has the contrast of body against ground and the
    background only the ground; along a ghost's it is the other way round (Cucchiara et al.,
    "Detecting moving objects, ghosts, and shadows in video streams", 2003, tell ghosts from
    objects by their motion; a still object has none, its outline does). The margin keeps out
    a thing that only changed its look (a sign lit up: both have its edge). Before foliage or
    posts the background's outline is as textured as the body's, and the long-term background
    decides: it saw the ground there before the person came, while a ghost is the ground again
    (dual backgrounds: Porikli, Ivanov and Haga, "Robust abandoned object detection using dual
    foregrounds", 2008). A blob that is mostly moving (a walker beside that sign) is left to
    heal_rate where it is still."""
    result = np.zeros(mask.shape, bool)
    x, y, width, height = cv2.boundingRect(mask)
    if width == 0:
        return result
    # the blobs' part of the image, with room for the outline and the 3 x 3 gradients
    rows = slice(max(y - 2, 0), y + height + 2)
    cols = slice(max(x - 2, 0), x + width + 2)
    count, labels = cv2.connectedComponents(mask[rows, cols], connectivity=connectivity)
    square = np.ones((3, 3), np.uint8)
    outline = cv2.morphologyEx(mask[rows, cols], cv2.MORPH_GRADIENT, square) > 0
    grown = cv2.dilate(labels.astype(np.float32), square).astype(np.int32)
    on_outline = grown[outline]
    view, before = gray[rows, cols].astype(np.float32), background.mean[rows, cols]
    in_view = np.bincount(on_outline, _gradient_magnitude(view)[outline], count)
    in_background = np.bincount(on_outline, _gradient_magnitude(before)[outline], count)
    inside = labels > 0
    owner = labels[inside]
    size = np.bincount(owner, minlength=count)

    def per_blob(values: np.ndarray) -> np.ndarray:
        return np.bincount(owner, values[inside], count)

    off_background = per_blob(np.abs(view - before))
    off_long_term = per_blob(np.abs(view - long_term[rows, cols]))
    flicker = per_blob(background.flicker[rows, cols]) / np.maximum(size, 1)
    moving_size = per_blob(moving[rows, cols])
    still_there = (
        (off_long_term >= LASTING_SHARE * off_background)
        & (flicker <= LASTING_FLICKER)
        & (size >= LASTING_MIN_PX)
    )
    standing = (moving_size <= STOPPED_MOVING_SHARE * size) & (
        (in_view > STOPPED_EDGE_RATIO * in_background)
        | (still_there & (in_view > LASTING_EDGE_RATIO * in_background))
    )
    standing[0] = False
    result[rows, cols] = standing[grown]
    return result


def _gradient_magnitude(image: np.ndarray) -> np.ndarray:
    return cv2.magnitude(cv2.Sobel(image, cv2.CV_32F, 1, 0), cv2.Sobel(image, cv2.CV_32F, 0, 1))


def _ellipse(size: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))


def _chromaticity(bgr: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: r, g chromaticity (R, G over R + G + B) and the sum R + G + B."""
    pixels = bgr.astype(np.float32)
    blue, green, red = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    total = blue + green + red  # per plane: a sum over the last axis of 3 is ~6x slower
    safe = np.maximum(total, 1.0)
    out = np.empty(pixels.shape, np.float32)
    np.divide(red, safe, out=out[..., 0])
    np.divide(green, safe, out=out[..., 1])
    out[..., 2] = total
    return out


METHOD: Method[BackgroundDetector] = Method.of(
    name="ssim_background",
    description="SSIM against a background mosaic kept in scene coordinates, with a learned "
    "flicker map; object silhouettes, undilated boxes",
    config=BackgroundConfig,
    make=BackgroundDetector,
)
