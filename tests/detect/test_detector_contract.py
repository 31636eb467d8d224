"""The contract of `detector.Detector`, run over every registered detector and the test-only
region detector: one Detection per accepted frame with its stamp, stale frames refused without
changing state, reset() forgets the history."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import region_detector

from tracker_detect.detector import CameraFrame, Detector, StaleFrameError
from tracker_detect.detectors import DETECTORS
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect

NS = 100_000_000
METHODS = [*DETECTORS, region_detector.METHOD]


WIDTH, HEIGHT = 200, 160


def walker() -> tuple[np.ndarray, np.ndarray]:
    """A real person (cut out of vtest.avi, 104 px tall): BGR pixels and mask."""
    data = np.load(Path(__file__).parent / "data" / "walker.npz")
    image = cv2.imdecode(data["image_jpeg"], cv2.IMREAD_COLOR)
    shape = tuple(data["mask_shape"])
    mask = np.unpackbits(data["mask_bits"])[: shape[0] * shape[1]].reshape(shape).astype(bool)
    return image, mask


def frames(count: int = 8, start: int = 1) -> list[CameraFrame]:
    """A textured scene with a bright yellow square and a person moving right (something every
    kind of detector finds: motion, colour, a person); the camera is static."""
    background = np.random.default_rng(0).integers(40, 120, (HEIGHT, WIDTH, 3), dtype=np.uint8)
    person, mask = walker()
    h, w = mask.shape
    out = []
    for k in range(start, start + count):
        image = background.copy()
        image[50:70, 10 + 8 * k : 30 + 8 * k] = (60, 250, 250)  # bright and yellow: motion, colour
        x, y = 100 + 8 * k - w, HEIGHT - h - 2
        image[y : y + h, x : x + w][mask] = person[mask]
        out.append(CameraFrame(k * NS, image, View.identity(WIDTH, HEIGHT)))
    return out


def make(method) -> Detector:
    detector = method.build(method.defaults())
    select = getattr(detector, "select_region", None)
    if select is not None:
        assert select(Rect(18, 50, 20, 20), frames(1)[0]) is None
    return detector


def summary(detection) -> tuple:
    return (
        detection.stamp_ns,
        detection.target_present,
        [(round(b.centroid_x, 6), round(b.centroid_y, 6), b.area) for b in detection.blobs],
    )


@pytest.mark.parametrize("method", METHODS, ids=[m.name for m in METHODS])
class TestDetectorContract:
    def test_one_detection_per_frame_with_its_stamp_in_the_scene(self, method):
        detector = make(method)
        assert isinstance(detector, Detector)
        results = [detector.process(frame) for frame in frames()]
        assert [r.stamp_ns for r in results] == [f.stamp_ns for f in frames()]
        assert any(r.blobs for r in results), "neither the square nor the person was detected"
        for r in results:
            for blob in r.blobs:
                assert 0 <= blob.centroid_x <= WIDTH and 0 <= blob.centroid_y <= HEIGHT

    def test_stale_frames_are_refused_without_changing_state(self, method):
        detector, twin = make(method), make(method)
        sequence = frames()
        for frame in sequence[:4]:
            detector.process(frame)
            twin.process(frame)
        for stale in (sequence[3], sequence[0]):
            with pytest.raises(StaleFrameError):
                detector.process(stale)
        for frame in sequence[4:]:
            assert summary(detector.process(frame)) == summary(twin.process(frame))

    def test_reset_forgets_the_history(self, method):
        detector = make(method)
        for frame in frames():
            detector.process(frame)
        detector.reset()
        fresh = make(method)
        for frame in frames(start=1):
            assert summary(detector.process(frame)) == summary(fresh.process(frame))
