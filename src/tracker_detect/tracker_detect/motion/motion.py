"""SSIM motion detection for a moving camera window (seed 000 §1 steps 2-7; no rclpy).

Frame k is compared with frame k - gap after ego-motion compensation (`registration`): the SSIM
map of the two aligned images is thresholded (SSIM <= 0.5 is motion), cleaned by the seed's
morphology (fill holes -> dilate -> fill holes -> dilate with a 7x7 diamond), and split into
4-connected blobs, reported in scene coordinates. The presence test says whether the blobs are
a measurement at all (total area >= 0.08 % of the compared area). Optionally the seed's double
detection also compares with an older reference frame, to keep slow or stopped objects.

`MotionDetector` keeps the last `gap` frames with their views and does all of this per frame;
the threshold is applied in `motion_mask`. `Blob`, `Detection` and `StaleFrameError` are the
shared detector types of `tracker_detect.detector`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from tracker_detect import blobs
from tracker_detect.blobs import fill_holes, find_blobs, odd_side, presence_test
from tracker_detect.detector import CameraFrame, Detection, StaleFrameError
from tracker_detect.registration import (
    Alignment,
    PixelMap,
    ShiftEstimate,
    View,
    align,
    phase_correlation_shift,
    relative_map,
    ssim_shift_search,
)
from tracker_detect.ssim import SsimParams, auto_downsample_factor, ssim_map
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

#: The seed's dilation element H (Principal.m), a 7x7 "diamond".
SEED_KERNEL = np.array(
    [
        [0, 0, 0, 1, 0, 0, 0],
        [0, 1, 1, 1, 1, 1, 0],
        [0, 1, 1, 1, 1, 1, 0],
        [1, 1, 1, 1, 1, 1, 1],
        [0, 1, 1, 1, 1, 1, 0],
        [0, 1, 1, 1, 1, 1, 0],
        [0, 0, 0, 1, 0, 0, 0],
    ],
    np.uint8,
)
KERNEL_SHAPES = ("seed", "ellipse", "rect", "cross")
MORPHOLOGY_STEPS = ("fill", "dilate", "erode", "open", "close")
SEED_MORPHOLOGY = ("fill", "dilate", "fill", "dilate")
COMPENSATION_MODES = ("known", "ssim_search", "phase_correlation", "off")
ESTIMATORS = ("ssim_search", "phase_correlation")


# --- mask and blobs ----------------------------------------------------------------------------


def structuring_element(shape: str = "seed", size: int = 7) -> np.ndarray:
    """Dilation element: the seed's 7x7 H ('seed', size ignored) or an OpenCV shape of size x size."""
    if shape == "seed":
        return SEED_KERNEL.copy()
    shapes = {"ellipse": cv2.MORPH_ELLIPSE, "rect": cv2.MORPH_RECT, "cross": cv2.MORPH_CROSS}
    if shape not in shapes:
        raise ValueError(f"kernel shape must be one of {', '.join(KERNEL_SHAPES)}; got '{shape}'")
    if size < 1 or size % 2 == 0:
        raise ValueError(f"kernel size must be odd and >= 1, got {size}")
    return cv2.getStructuringElement(shapes[shape], (size, size))


def motion_mask(
    similarity: np.ndarray,
    threshold: float = 0.5,
    steps: Sequence[str] = SEED_MORPHOLOGY,
    kernel: np.ndarray | None = None,
) -> np.ndarray:
    """Binary (0/1 uint8) mask of SSIM <= threshold, then `steps` in order (seed: fill, dilate x2)."""
    mask: np.ndarray = (similarity <= threshold).astype(np.uint8)
    element = SEED_KERNEL if kernel is None else kernel
    for step in steps:
        if step == "fill":
            mask = fill_holes(mask)
        elif step == "dilate":
            mask = cv2.dilate(mask, element)
        elif step == "erode":
            mask = cv2.erode(mask, element)
        elif step == "open":
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, element)
        elif step == "close":
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, element)
        else:
            raise ValueError(
                f"unknown morphology step '{step}' (known: {', '.join(MORPHOLOGY_STEPS)})"
            )
    return mask


# --- the detector ------------------------------------------------------------------------------


@dataclass(frozen=True)
class DetectorConfig:
    """Parameters of `MotionDetector` (defaults: the seed's recommended values, §7)."""

    gap: int = param(3, "frames between the compared images (seed: 3)", min=1, max=100)
    threshold: float = param(0.5, "SSIM at or below which a pixel is motion", min=-1.0, max=1.0)
    morphology: tuple[str, ...] = param(
        list(SEED_MORPHOLOGY),
        "mask clean-up steps in order, each one of: " + ", ".join(MORPHOLOGY_STEPS),
        validator=lambda v: (
            None
            if all(s in MORPHOLOGY_STEPS for s in v)
            else f"morphology steps must be among {', '.join(MORPHOLOGY_STEPS)}"
        ),
    )
    kernel_shape: str = param(
        "seed", "dilation element ('seed' = the thesis' 7x7 H)", choices=KERNEL_SHAPES
    )
    kernel_size: int = odd_side(
        7, "odd side of the element for shapes other than 'seed'", "kernel_size"
    )
    connectivity: int = blobs.connectivity(4)
    presence_fraction: float = blobs.presence_fraction(0.0008)  # 0.08 %: the seed's
    min_blob_area: float = blobs.min_blob_area(0.0)  # 0: keep all, the seed
    compensation: str = param(
        "known",
        "ego-motion compensation: known (from the poses), ssim_search (seed's exhaustive "
        "simplified-SSIM search), phase_correlation, off",
        choices=COMPENSATION_MODES,
    )
    search_radius: int = param(30, "shift estimators search +- this", min=0, max=200, unit="px")
    search_window: int = param(5, "uniform window of the simplified SSIM", min=1, max=31, unit="px")
    search_pyramid_levels: int = param(
        2,
        "coarse-to-fine levels of ssim_search (0 = the seed's full-resolution search)",
        min=0,
        max=5,
    )
    phase_candidates: int = param(
        5, "phase_correlation: peaks verified by the simplified SSIM", min=1, max=50
    )
    subpixel_alignment: bool = param(
        True, "resample fractional shifts bilinearly (else round them)"
    )
    auto_downsample: bool = blobs.auto_downsample(True)
    min_overlap_fraction: float = param(
        0.1,
        "compare only when the aligned images overlap at least this much",
        min=0.01,
        max=1.0,
    )
    double_detection: bool = param(
        False, "also compare with the frame where motion began (slow / stopped objects)"
    )
    reference_max_age: int = param(
        50, "frames a double-detection reference is kept at most", min=1, max=100000
    )
    ssim: SsimParams = field(default_factory=SsimParams)

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this config is unusable beyond its fields' own ranges (empty when it is fine)."""
        return []


@dataclass
class _Frame:
    image: np.ndarray
    view: View  # given, or assumed / dead-reckoned when the pose is unknown
    pose_known: bool
    stamp_ns: int


@dataclass
class _Comparison:
    similarity: np.ndarray  # full-image map, ones outside the compared part
    alignment: Alignment
    pixel_map: PixelMap
    estimate: ShiftEstimate | None
    fallback: bool


class MotionDetector:
    """Per-frame SSIM motion detection against the frame `gap` frames earlier (see module doc).

    `process(image, stamp_ns, view)` takes a grey (H, W) image, its stamp and where it lies in
    the scene. view=None means the pose is unknown: with an estimator selected the view is dead
    reckoned (the view of frame k - gap moved by the estimated shift; the first `gap` frames are
    taken to be at the origin), otherwise the camera is taken to be static at the origin. Stamps
    must increase; a change of image size clears the history.
    """

    def __init__(self, config: DetectorConfig | None = None) -> None:
        self.config = config or DetectorConfig()
        self._history: deque[_Frame] = deque()
        self._reference: _Frame | None = None
        self._reference_age = 0
        self._last_stamp: int | None = None
        self._kernel = structuring_element(self.config.kernel_shape, self.config.kernel_size)

    def reconfigure(self, config: DetectorConfig) -> None:
        """Use `config` from the next frame on; a different gap keeps the history it can."""
        self.config = config
        self._kernel = structuring_element(config.kernel_shape, config.kernel_size)
        while len(self._history) > config.gap:
            self._history.popleft()
        if not config.double_detection:
            self._reference = None

    def reset(self) -> None:
        """Forget all frames (the next `gap` frames are not compared)."""
        self._history.clear()
        self._reference = None
        self._last_stamp = None

    @property
    def history_length(self) -> int:
        return len(self._history)

    def process(self, image: np.ndarray, stamp_ns: int, view: View | None = None) -> Detection:
        """Detect motion in `image`; raises ValueError (state untouched) for unusable input."""
        frame, previous, comparison, reset = self._advance(image, stamp_ns, view)
        if previous is None or comparison is None:
            return Detection(stamp_ns, frame.view, [], False, False, history_reset=reset)
        return self._detect(frame, previous, comparison, reset)

    def change_map(
        self, image: np.ndarray, stamp_ns: int, view: View | None = None
    ) -> np.ndarray | None:
        """`process`'s SSIM map alone (None while it has none), without its mask and blobs:
        for a caller that only needs where the image changed."""
        if self.config.double_detection:  # its reference follows the blobs
            return self.process(image, stamp_ns, view).similarity
        _, _, comparison, _ = self._advance(image, stamp_ns, view)
        return None if comparison is None else comparison.similarity

    def _advance(
        self, image: np.ndarray, stamp_ns: int, view: View | None
    ) -> tuple[_Frame, _Frame | None, _Comparison | None, bool]:
        """Take the frame into the history: it, the frame `gap` before it (None while the
        history fills), their comparison, and whether the history was reset."""
        gray = _check_image(image)
        if view is not None and (view.width, view.height) != (gray.shape[1], gray.shape[0]):
            raise ValueError(
                f"view is for {view.width}x{view.height} px, image is "
                f"{gray.shape[1]}x{gray.shape[0]}"
            )
        if self._last_stamp is not None and stamp_ns <= self._last_stamp:
            raise StaleFrameError(
                f"stamp {stamp_ns} ns is not newer than the last frame's {self._last_stamp} ns"
            )
        self._last_stamp = stamp_ns
        reset = bool(self._history) and self._history[-1].image.shape != gray.shape
        if reset:
            self._history.clear()
            self._reference = None
        identity = View.identity(gray.shape[1], gray.shape[0])
        frame = _Frame(gray.copy(), view or identity, view is not None, stamp_ns)
        if len(self._history) < self.config.gap:
            self._history.append(frame)
            return frame, None, None, reset
        previous = self._history.popleft()
        comparison = self._compare(previous, frame)
        if not frame.pose_known and self.config.compensation in ESTIMATORS:
            # Dead reckoning: the unknown view is the earlier one moved by the estimated shift.
            m = comparison.pixel_map if comparison else PixelMap()
            frame.view = previous.view.translated(m.tx, m.ty)
        self._history.append(frame)
        return frame, previous, comparison, reset

    def _detect(
        self, frame: _Frame, previous: _Frame, comparison: _Comparison, reset: bool
    ) -> Detection:
        c = self.config
        similarity = comparison.similarity
        if c.double_detection and self._reference is not None:
            self._reference_age += 1
            reference = self._compare(self._reference, frame)
            if reference is None or self._reference_age > c.reference_max_age:
                self._reference = None
            else:
                np.minimum(similarity, reference.similarity, out=similarity)
        view = frame.view
        mask = motion_mask(similarity, c.threshold, c.morphology, self._kernel)
        blobs = [
            b
            for b in find_blobs(mask, similarity, view, c.connectivity)
            if b.area >= c.min_blob_area
        ]
        compared_pixels = comparison.alignment.area
        present = presence_test(
            sum(b.pixel_count for b in blobs), compared_pixels, c.presence_fraction
        )
        if c.double_detection:
            if not present:
                self._reference = None
            elif self._reference is None:
                self._reference, self._reference_age = previous, 0
        prev_view = previous.view
        m = comparison.pixel_map
        return Detection(
            frame.stamp_ns,
            view,
            blobs,
            present,
            True,
            compared_area=compared_pixels * view.scale_x * view.scale_y,
            ego_shift=(m.tx * prev_view.scale_x, m.ty * prev_view.scale_y),
            shift_estimate=comparison.estimate,
            registration_fallback=comparison.fallback,
            similarity=similarity,
            mask=mask,
            history_reset=reset,
        )

    def _compare(self, previous: _Frame, frame: _Frame) -> _Comparison | None:
        """Align `previous` to `frame` and compute their SSIM map; None without enough overlap."""
        c = self.config
        pixel_map, estimate, fallback = self._pixel_map(previous, frame)
        alignment = align(previous.image, frame.image, pixel_map, c.subpixel_alignment)
        min_area = c.min_overlap_fraction * frame.image.size
        if alignment is None or alignment.area < max(min_area, 1):
            return None
        x0, y0, x1, y1 = alignment.roi
        factor = auto_downsample_factor((y1 - y0, x1 - x0)) if c.auto_downsample else 1
        if min(y1 - y0, x1 - x0) // factor < c.ssim.win_size + 1:
            return None
        local = ssim_map(
            alignment.prev, alignment.curr, c.ssim, valid=True, downsample_factor=factor
        )
        similarity = np.ones(frame.image.shape, np.float32)
        paste_map(similarity, local, alignment.roi, c.ssim.border, factor)
        return _Comparison(similarity, alignment, pixel_map, estimate, fallback)

    def _pixel_map(
        self, previous: _Frame, frame: _Frame
    ) -> tuple[PixelMap, ShiftEstimate | None, bool]:
        c = self.config
        if c.compensation == "off":
            return PixelMap(), None, False
        both_known = previous.pose_known and frame.pose_known
        known = relative_map(previous.view, frame.view) if both_known else PixelMap()
        if c.compensation == "known":
            return known, None, False
        # Estimators look for the residual shift after the known alignment (jitter), or for the
        # whole shift when the pose is unknown (the known map is then the identity).
        coarse = align(previous.image, frame.image, known, subpixel=True)
        if coarse is None or min(coarse.prev.shape) < 4 * c.search_window:
            return known, None, True
        try:
            estimate = self._estimate(coarse.prev, coarse.curr)
        except ValueError:
            return known, None, True
        if max(abs(estimate.dx), abs(estimate.dy)) > c.search_radius:
            return known, estimate, True
        return known.shifted(estimate.dx, estimate.dy), estimate, False

    def _estimate(self, prev: np.ndarray, curr: np.ndarray) -> ShiftEstimate:
        c = self.config
        if c.compensation == "phase_correlation":
            return phase_correlation_shift(
                prev, curr, candidates=c.phase_candidates, window=c.search_window, params=c.ssim
            )
        return ssim_shift_search(
            prev,
            curr,
            radius=c.search_radius,
            window=c.search_window,
            pyramid_levels=c.search_pyramid_levels,
            params=c.ssim,
        )


def _check_image(image: np.ndarray) -> np.ndarray:
    array = np.asarray(image)
    if array.ndim != 2 or array.size == 0:
        raise ValueError(f"expected a grey (H, W) image, got shape {array.shape}")
    if array.dtype != np.uint8:
        if not np.issubdtype(array.dtype, np.number) or not np.all(np.isfinite(array)):
            raise ValueError(f"image must be finite numbers, got dtype {array.dtype}")
        array = array.astype(np.float32)
    return array


def paste_map(
    full: np.ndarray, local: np.ndarray, roi: tuple[int, int, int, int], border: int, factor: int
) -> None:
    """Write a 'valid' (possibly downsampled) SSIM map back into full-image pixels."""
    x0, y0, x1, y1 = roi
    if factor > 1:
        local = np.repeat(np.repeat(local, factor, axis=0), factor, axis=1)
    top, left = y0 + border * factor, x0 + border * factor
    rows = min(local.shape[0], y1 - top)
    cols = min(local.shape[1], x1 - left)
    full[top : top + rows, left : left + cols] = local[:rows, :cols]


class SsimDetector:
    """Seed 000's SSIM motion detection (`MotionDetector`) as a `detector.Detector`."""

    def __init__(self, config: DetectorConfig) -> None:
        self.motion = MotionDetector(config)

    @property
    def config(self) -> DetectorConfig:
        return self.motion.config

    @property
    def estimates_ego_motion(self) -> bool:
        return self.motion.config.compensation in ESTIMATORS

    def process(self, frame: CameraFrame) -> Detection:
        return self.motion.process(frame.gray, frame.stamp_ns, frame.view)

    def reset(self) -> None:
        self.motion.reset()

    def reconfigure(self, config: DetectorConfig) -> None:
        """New parameter values from the next frame on, keeping the history it can."""
        self.motion.reconfigure(config)


METHOD: Method[SsimDetector] = Method.of(
    name="ssim",
    description="SSIM change detection between frames `gap` apart after ego-motion "
    "compensation, morphology, connected blobs (seed 000)",
    config=DetectorConfig,
    make=SsimDetector,
)
