"""How a seeded detector (CamShift) is started, handed over and guided, image by image (no rclpy).

A seeded detector follows one target it was started on. Besides its images it reads:
- an initial region (a parameter), used on the first image;
- another tracker's target for the image (the hand-over source, e.g. the motion tracker's): when
  it was measured in this image (confirmed, not coasting) in at least `handover_min_hits` images,
  it is offered to the detector, which takes it when not tracking, or when it judges its own
  target wrong (CamShift: the offered box's colours match its model better); and while the very
  track that started the detector is still measured apart from the detector's box, the detector
  is the one that drifted (the track still measures the walker): it is started there again
  (`handover_follow_source`). Once that track is lost (the person stopped, and change detection
  no longer sees them) the detector is on its own;
- its own tracker's target (guidance): its position moved by its velocity to the image's stamp is
  where the search starts, when at most `guide_max_age` old;
- with `handover_passthrough`, an image where the detector finds nothing reports the measured
  offered box (score 0), so whatever follows the detections follows the other tracker's target
  until the detector takes over.
The detector node converts messages into `Offer` and `Guidance` and calls `SeededSession.step`;
the in-process pipeline calls the same, so both decide alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from tracker_detect.detector import Blob, CameraFrame, Detection, SeededDetector
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.params import ParamSpec, param, specs_of

NS_PER_S = 1_000_000_000
SAME_OBJECT_IOU = 0.3  # an offered box overlapping the detector's own this much is the same object


@dataclass(frozen=True)
class Offer:
    """Another tracker's target in one image."""

    stamp_ns: int
    track_id: int
    box: Rect  # scene px
    measured: bool  # locked, and updated by a measurement in this image (not coasting)
    hits: int  # images it was measured in since it began


@dataclass(frozen=True)
class Guidance:
    """The own tracker's target: position [scene px] and velocity [px/s] at `stamp_ns`."""

    stamp_ns: int
    x: float
    y: float
    vx: float
    vy: float

    def at(self, stamp_ns: int) -> tuple[float, float]:
        age = (stamp_ns - self.stamp_ns) / NS_PER_S
        return self.x + self.vx * age, self.y + self.vy * age

    def age(self, stamp_ns: int) -> float:
        return (stamp_ns - self.stamp_ns) / NS_PER_S


@dataclass(frozen=True)
class SeedingConfig:
    """How a seeded detector (camshift) is started, handed over and guided: the detector node's
    parameters beside the method's."""

    initial_region: tuple[float, ...] = param(
        [0.0, 0.0, 0.0, 0.0],
        "seeded detectors (camshift): x, y, w, h to start on in the first image (zero size: none)",
        unit="scene px",
        validator=lambda v: None if len(v) == 4 else "initial_region needs x, y, width, height",
    )
    handover: bool = param(
        True,
        "seeded detectors: offer the box of the locked target on `handover_target` that was "
        "measured in that image (e.g. the motion tracker's): taken when not tracking, or when "
        "the detector judges its own target wrong (camshift: rehandover_similarity)",
    )
    handover_passthrough: bool = param(
        False,
        "seeded detectors: while the detector finds nothing, report the measured hand-over box "
        "of the image (score 0), so the camera follows the other tracker's target until this "
        "detector takes over",
    )
    handover_follow_source: bool = param(
        True,
        "seeded detectors: while the track whose box started the detector is measured apart from "
        "the detector's box, start it there again (the detector drifted)",
    )
    handover_min_hits: int = param(
        5,
        "seeded detectors: hand over only a target measured in at least this many frames",
        min=1,
        max=100000,
    )
    guide_from_target: bool = param(
        True, "seeded detectors: search each image where `target`'s track is predicted to be"
    )
    guide_max_age: float = param(
        0.5,
        "seeded detectors: use a `target` at most this old for the guidance",
        min=0.0,
        max=10.0,
        unit="s",
    )

    def problems(self) -> list[str]:
        return []


#: The seeding's node parameters (the detector node declares them beside the method's).
SEEDING_PARAMETERS: tuple[ParamSpec, ...] = specs_of(SeedingConfig)


def initial_region(values: Sequence[float]) -> Rect | None:
    """The `initial_region` parameter (x, y, w, h) as a region; None for a zero size."""
    x, y, w, h = (float(v) for v in values)
    return Rect(x, y, w, h) if w > 0 and h > 0 else None


@dataclass(frozen=True)
class OfferResult:
    taken: bool
    again: bool  # taken while tracking something else (a re-hand-over)
    refused: str | None  # why a detector that was not tracking refused it


@dataclass(frozen=True)
class SeededStep:
    detection: Detection
    initial: str | None  # the outcome of the initial region, on the image it was tried
    offer: OfferResult | None  # the outcome of this image's offer, when one was made


class SeededSession:
    """One seeded detector with its initial region, hand-over policy and guidance."""

    def __init__(
        self,
        detector: SeededDetector,
        config: SeedingConfig | None = None,
        initial_region: Rect | None = None,
    ) -> None:
        self.detector = detector
        self.config = config or SeedingConfig()
        self.pending_region = initial_region

        self.source_id: int | None = None  # the track whose offer the detector last took
        self.last_box: Rect | None = None  # the detector's own last box

    def reset(self) -> None:
        """A new epoch: forget the source track and the last box."""
        self.source_id, self.last_box = None, None

    def offer(self, frame: CameraFrame, offered: Offer) -> OfferResult | None:
        """Offer `offered`'s box in `frame` when the policy allows; None when it does not."""
        if not (self.config.handover and offered.measured):
            return None  # only a measured box is worth learning a model from
        if offered.hits < self.config.handover_min_hits:
            return None  # a young track's box is often a fragment
        was_tracking = self.detector.tracking
        if was_tracking and self._drifted_from(offered):
            reason = self.detector.select_region(offered.box, frame)
        else:
            reason = self.detector.hand_over(offered.box, frame)
        if reason is None:
            self.source_id, self.last_box = offered.track_id, offered.box
        refused = reason if reason is not None and not was_tracking else None
        return OfferResult(reason is None, reason is None and was_tracking, refused)

    def _drifted_from(self, offered: Offer) -> bool:
        """The source track, still measured, lies apart from the detector's box."""
        return (
            self.config.handover_follow_source
            and offered.track_id == self.source_id
            and self.last_box is not None
            and offered.box.iou(self.last_box) < SAME_OBJECT_IOU
        )

    def step(
        self, frame: CameraFrame, offered: Offer | None = None, guide: Guidance | None = None
    ) -> SeededStep:
        """Start (initial region), take the offer, place the search, detect, pass through."""
        initial = None
        if self.pending_region is not None:
            initial = self.detector.select_region(self.pending_region, frame) or "tracking started"
            self.pending_region = None
        result = self.offer(frame, offered) if offered is not None else None
        handed_over = result is not None and result.taken
        if guide is not None and not handed_over and self._guided(guide, frame.stamp_ns):
            self.detector.guide(guide.at(frame.stamp_ns))
        detection = self.detector.process(frame)
        if detection.blobs:
            self.last_box = detection.blobs[0].bbox
        elif self.config.handover_passthrough:
            detection = passed_through(detection, offered)
        return SeededStep(detection, initial, result)

    def _guided(self, guide: Guidance, stamp_ns: int) -> bool:
        if not (self.config.guide_from_target and self.detector.tracking):
            return False
        return 0.0 <= guide.age(stamp_ns) <= self.config.guide_max_age


def passed_through(detection: Detection, offered: Offer | None) -> Detection:
    """`detection` reporting the measured offered box (score 0) instead of nothing."""
    if offered is None or not offered.measured:
        return detection
    box = offered.box
    cx, cy = box.center
    blob = Blob(cx, cy, box, box.area, max(round(box.area), 1), 0.0)
    return replace(detection, blobs=[blob], target_present=True)
