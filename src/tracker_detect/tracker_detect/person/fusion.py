"""Motion proposes, the person model decides: the background detector and the person model on
one camera view (no rclpy).

`FusionDetector` (`method: person_motion`) runs the SSIM background detector (`background`) and
the person model (`person`) on every camera image and returns:
- every person box the model finds, labelled `person` with its score -- also where motion saw
  nothing and one box per person where one blob holds two. Motion vouches for a box: one with
  less than `motion_share` of its pixels in the motion mask scores at most `still_score`, below
  the tracker's confident level (`byte`'s `high`, 0.5), so it continues a person's track (they
  stopped) but never starts one: a sign, a poster or a statue the model takes for a person is
  never followed, as in Frigate, where only motion makes the model look;
- every motion blob no person box explains, labelled `motion` (a flag, a tree, a car, a person
  the model missed), scored by its motion's strength (1 - mean SSIM): a blob is explained when
  person boxes cover at least `explained_share` of its box. Target selection follows only the
  labels it is told (`track_labels`), so these blobs are tracked and published but not followed
  by default.

The model runs on a thread of its own while the motion detector works (onnxruntime, OpenCV and
NumPy release the GIL): in lockstep the frame waits for the slower of the two, not for both.
It looks at the whole camera view at once, not at crops around the blobs (and last
frame's people): measured on the benchmark, crops at 128 px scored the clip's in-view MOTA 0.547
against 0.840 (parts of people and crop edges taken for people) and ran at 11 against 31
frames/s on the busy clip, as one inference per crop adds up (docs/results/people.md). The
motion detector's mask, similarity and registration pass through, so its debug images work as
with `ssim_background`.
"""

from __future__ import annotations

import functools
from concurrent.futures import ThreadPoolExecutor, wait
from dataclasses import dataclass, replace

import cv2
import numpy as np

from tracker_detect.background.background import BackgroundConfig, BackgroundDetector
from tracker_detect.detector import Blob, CameraFrame, Detection
from tracker_detect.person.person import PersonConfig, PersonModel, box_blob
from tracker_msgs_py.geometry import intersection_areas
from tracker_msgs_py.labels import MOTION
from tracker_msgs_py.params import check_config, param, params_of
from tracker_msgs_py.registry import Method


@dataclass(frozen=True)
class FusionConfig:
    """How motion blobs and person boxes are combined."""

    background: BackgroundConfig = params_of(BackgroundConfig)
    # the person model keeps its weak boxes: the tracker's second association stage uses them
    person: PersonConfig = params_of(PersonConfig, score_threshold=0.2)
    explained_share: float = param(
        0.5,
        "a motion blob whose box person boxes cover at least this share is those people's "
        "(else it is published labelled motion)",
        min=0.01,
        max=1.0,
    )
    motion_blobs: bool = param(True, "publish the blobs no person explains (label motion)")
    motion_share: float = param(
        0.05,
        "share of a person box's pixels in the motion mask that vouches for it",
        min=0.0,
        max=1.0,
    )
    still_score: float = param(
        0.45,
        "score cap of a person box motion does not vouch for (below the tracker's high: it "
        "continues a track, never starts one; 1: no cap)",
        min=0.0,
        max=1.0,
    )

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        return []


def _boxes(blobs: list[Blob]) -> np.ndarray:
    """(N, 4) x, y, width, height of the blobs' boxes."""
    if not blobs:
        return np.zeros((0, 4))
    return np.array([(b.bbox.x, b.bbox.y, b.bbox.width, b.bbox.height) for b in blobs])


def unexplained(motion: list[Blob], people: list[Blob], share: float) -> list[Blob]:
    """The motion blobs whose boxes the person boxes cover less than `share` of (the covered
    area summed over the people, so a blob holding two people is theirs), labelled MOTION and
    scored, like the person boxes, higher = surer: the motion's strength, 1 - the blob's mean
    SSIM, in [0, 1]."""
    if not motion:
        return []
    blob_boxes = _boxes(motion)
    covered = (
        intersection_areas(blob_boxes, _boxes(people)).sum(axis=1)
        if people
        else np.zeros(len(motion))
    )
    areas = np.maximum(blob_boxes[:, 2] * blob_boxes[:, 3], 1e-9)
    keep = covered / areas < share
    return [
        replace(blob, label=MOTION, score=min(max(1.0 - blob.score, 0.0), 1.0))
        for blob, k in zip(motion, keep, strict=True)
        if k
    ]


def moving_shares(boxes: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(N,) share of each (x0, y0, x1, y1, ...) image-px box's pixels set in the 0/1 mask."""
    height, width = mask.shape
    integral = cv2.integral(mask.astype(np.uint8))
    x0 = np.clip(np.floor(boxes[:, 0]), 0, width).astype(int)
    y0 = np.clip(np.floor(boxes[:, 1]), 0, height).astype(int)
    x1 = np.clip(np.ceil(boxes[:, 2]), 0, width).astype(int)
    y1 = np.clip(np.ceil(boxes[:, 3]), 0, height).astype(int)
    counts = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    areas = np.maximum((x1 - x0) * (y1 - y0), 1)
    result: np.ndarray = counts / areas
    return result


def vouched_scores(boxes: np.ndarray, mask: np.ndarray, config: FusionConfig) -> np.ndarray:
    """The boxes' scores, capped at `still_score` where motion does not vouch for them."""
    scores = boxes[:, 4].astype(float)
    still = moving_shares(boxes, mask) < config.motion_share
    return np.where(still, np.minimum(scores, config.still_score), scores)


@functools.cache
def _model_worker() -> ThreadPoolExecutor:
    """The one thread the person model runs on beside the motion detector (made on first use:
    detectors built only to validate parameters start none)."""
    return ThreadPoolExecutor(max_workers=1, thread_name_prefix="person-model")


class FusionDetector:
    """The background detector's blobs and the person model's boxes of one frame, labelled.

    Not `DeferredLearning`: the background models learn the frame before at the start of
    `process`, while the model looks at this one on the other core, so learning adds no time to
    a frame (deferred past publishing, it would run with the second core idle)."""

    estimates_ego_motion = False

    def __init__(self, config: FusionConfig) -> None:
        self.motion = BackgroundDetector(config.background)
        self.model = PersonModel(config.person)
        self.config = config

    def process(self, frame: CameraFrame) -> Detection:
        # The model runs on a second core while the motion detector works on this one: neither
        # uses the other's result, so the boxes are the same as one after the other.
        looking = _model_worker().submit(self.model.detect, frame.image)
        try:
            moving = self.motion.process(frame)  # raises on a stale frame or a wrong view
        except Exception:
            wait([looking])  # the model is done with this frame; the motion detector's error
            raise  # names the cause, not what the model made of the same bad frame
        boxes = looking.result()
        if moving.compared and moving.mask is not None:
            boxes[:, 4] = vouched_scores(boxes, moving.mask, self.config)
        view = moving.view
        people = [box_blob(box, view) for box in boxes]
        blobs = list(people)
        if self.config.motion_blobs and moving.target_present:
            blobs += unexplained(moving.blobs, people, self.config.explained_share)
        blobs.sort(key=lambda b: -b.area)
        return replace(
            moving,
            blobs=blobs,
            target_present=bool(blobs),
            compared=True,
            compared_area=view.rect.width * view.rect.height,
        )

    def reset(self) -> None:
        self.motion.reset()

    def reconfigure(self, config: FusionConfig) -> None:
        """New parameter values from the next frame on (the background and model are kept)."""
        self.motion.reconfigure(config.background)
        self.model = PersonModel(config.person)
        self.config = config


METHOD: Method[FusionDetector] = Method.of(
    name="person_motion",
    description="motion proposes, the person model decides: the SSIM background detector's "
    "blobs and the person model's boxes on each camera image; person boxes labelled person, "
    "blobs no person explains labelled motion",
    config=FusionConfig,
    make=FusionDetector,
)
