"""The detector plug-in shape: one camera frame in, one `Detection` out (no rclpy).

- `CameraFrame`: a camera image with its stamp and, when known, where it lies in the scene
  (`registration.View`); the colour image is kept, the grey one made on first use.
- `Detector`: what every detector offers -- SSIM motion detection (`motion.SsimDetector`,
  `background.BackgroundDetector`), CamShift colour tracking (`camshift.CamShiftTracker`), MOG2
  background subtraction for a static camera (`mog2.Mog2Detector`), the person model
  (`person.PersonDetector`) and its fusion with motion (`fusion.FusionDetector`). Methods
  seeded from a rectangle (CamShift) also implement `SeededDetector.select_region`, which the
  detector node serves as `select_region`, and `guide`, where the node places the next search
  at the tracker's prediction.
- `Detection` / `Blob`: the result, in scene coordinates (tracker_msgs/BlobArray).

Contract (tests/detect/test_detector_contract.py, for every registered detector): one Detection
per accepted frame, with the frame's stamp; a frame not newer than the last raises
`StaleFrameError` and changes nothing; `reset()` forgets the history; `reconfigure(config)` takes
new parameter values and keeps the history it can. A method whose `build`
cannot start (a learned model that will not load) raises `DetectorUnavailableError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, Protocol, runtime_checkable

import cv2
import numpy as np

from tracker_detect.registration import ShiftEstimate, View
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.labels import MOTION


class DetectorUnavailableError(RuntimeError):
    """A detector that cannot start: a model file missing or damaged, no runtime to run it. The
    message names the cause in one line; the node stops at start-up with it."""


class StaleFrameError(ValueError):
    """A frame whose stamp is not newer than the last accepted one (out of order or duplicate)."""


class UnusableViewError(ValueError):
    """A frame whose view the detector cannot work with (one that would grow its background
    beyond what it can hold); raised before any state changes, so the next frame is as good."""


@dataclass(frozen=True)
class Blob:
    """A detected region, in scene coordinates (tracker_msgs/Blob)."""

    centroid_x: float  # scene px, mean of the pixel centres
    centroid_y: float
    bbox: Rect  # scene px, tight box of the pixels
    area: float  # scene px^2 (pixel count x scene px per image px squared)
    pixel_count: int  # image pixels
    score: float  # the method's score (SSIM: mean SSIM over the blob, lower = stronger motion)
    angle: float = 0.0  # rad, oriented box's rotation from the scene x axis towards y
    oriented_size: tuple[float, float] | None = None  # scene px, oriented box's sides (CamShift)
    label: str = MOTION  # class: PERSON from the person model, MOTION when nothing classified it


@dataclass
class Detection:
    """Everything a detector found in one frame."""

    stamp_ns: int
    view: View  # where the current image lies in the scene
    blobs: list[Blob]  # largest first
    target_present: bool  # the presence test
    compared: bool  # False while the method has too little history (or no overlap)
    compared_area: float = 0.0  # scene px^2 of image the method could judge
    ego_shift: tuple[float, float] = (0.0, 0.0)  # scene px, camera shift the method compensated
    shift_estimate: ShiftEstimate | None = None  # the ego-motion estimator's raw result
    registration_fallback: bool = False  # estimate rejected (beyond the radius): known map used
    similarity: np.ndarray | None = None  # (H, W) float32 per-pixel score in [0, 1], image px
    mask: np.ndarray | None = None  # (H, W) uint8 0/1 foreground mask, image px
    history_reset: bool = False  # the image size (static-camera methods: the view) changed:
    # the history was cleared first


@dataclass(frozen=True, eq=False)
class CameraFrame:
    """One camera image: (H, W) grey or (H, W, 3) BGR uint8, its stamp, and its view (None: the
    pose is unknown)."""

    stamp_ns: int
    image: np.ndarray
    view: View | None = None

    @cached_property
    def gray(self) -> np.ndarray:
        """(H, W) uint8 luma (the seed's weights, as cv2's BGR2GRAY)."""
        if self.image.ndim == 2:
            return self.image
        return cv2.cvtColor(np.ascontiguousarray(self.image), cv2.COLOR_BGR2GRAY)

    @property
    def bgr(self) -> np.ndarray:
        """(H, W, 3) uint8 colour (grey replicated for a mono image)."""
        if self.image.ndim == 3:
            return self.image
        return np.repeat(self.image[:, :, None], 3, axis=2)

    @property
    def size(self) -> tuple[int, int]:
        """Width, height in px."""
        return int(self.image.shape[1]), int(self.image.shape[0])


def checked_view(frame: CameraFrame, last_stamp_ns: int | None) -> View:
    """The frame's view (the identity when its pose is unknown), after the checks every detector
    makes before touching its state: the view is for the image's size (else ValueError) and the
    stamp is newer than the last accepted frame's (else StaleFrameError)."""
    width, height = frame.size
    if frame.view is not None and (frame.view.width, frame.view.height) != (width, height):
        raise ValueError(
            f"view is for {frame.view.width}x{frame.view.height} px, image is {width}x{height}"
        )
    if last_stamp_ns is not None and frame.stamp_ns <= last_stamp_ns:
        raise StaleFrameError(
            f"stamp {frame.stamp_ns} ns is not newer than the last frame's {last_stamp_ns} ns"
        )
    return frame.view or View.identity(width, height)


@runtime_checkable
class Detector(Protocol):
    """A per-frame detector; see the module docstring for its contract."""

    @property
    def estimates_ego_motion(self) -> bool:
        """True when it can work without a known pose (it estimates the camera's motion)."""
        ...

    def process(self, frame: CameraFrame) -> Detection:
        """Detect in `frame`; raises StaleFrameError or ValueError (state untouched)."""
        ...

    def reset(self) -> None:
        """Forget all history (a new replay epoch)."""
        ...

    def reconfigure(self, config: Any) -> None:
        """New parameter values (the config its `Method` builds it from) from the next frame
        on, keeping the history it can."""
        ...


@runtime_checkable
class DeferredLearning(Protocol):
    """A detector whose models learn from a frame after its detections are made
    (`background.BackgroundDetector`): a node calls `learn_last_frame` once it has published
    them, so the learning is not in the latency; otherwise the next `process` does it first."""

    def learn_last_frame(self) -> None:
        """Let the models learn the last processed frame, if they have not yet."""
        ...


@runtime_checkable
class SeededDetector(Detector, Protocol):
    """A detector started from a rectangle the user draws over its target (CamShift-style)."""

    def select_region(self, region: Rect, frame: CameraFrame) -> str | None:
        """Start on `region` (scene px) of `frame`; None, or why it cannot."""
        ...

    def hand_over(self, region: Rect, frame: CameraFrame) -> str | None:
        """Offered `region` of `frame` by another tracker (e.g. the motion tracker's measured
        target): take it when not tracking, or when the detector judges its own target wrong;
        None when taken, else why not."""
        ...

    @property
    def tracking(self) -> bool:
        """True while it has a target and has not lost it."""
        ...

    def guide(self, centre: tuple[float, float]) -> None:
        """Search next around `centre` (scene px), e.g. a filter's prediction."""
        ...
