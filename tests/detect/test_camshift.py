"""CamShift colour tracking (tracker_detect.camshift.camshift): boxes at IoU >= 0.5 on a coloured target,
on a static and a moving (panning, zoomed-out) view, misses instead of OpenCV's (0, 0) window,
loss and re-acquisition, prediction-guided search, and the selection's errors."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from colour_scene import (  # noqa: I001
    AXES,
    SCENE_H,
    SCENE_W,
    TARGET_BGR,
    background,
    scene_with_target,
    target_position,
    true_box,
)

from tracker_detect.camshift.camshift import CamShiftConfig, CamShiftTracker, OrientedBox
from tracker_detect.detector import CameraFrame, SeededDetector
from tracker_detect.detectors import DETECTORS
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect

NS = 50_000_000  # 20 fps, the thesis's rate


def frame(k: int, scene: np.ndarray, view: View | None = None) -> CameraFrame:
    """Camera image of `view` (scene rectangle, resampled to its image size) or the whole scene."""
    if view is None:
        return CameraFrame(k * NS, scene, View.identity(SCENE_W, SCENE_H))
    r = view.rect
    crop = scene[round(r.y) : round(r.y + r.height), round(r.x) : round(r.x + r.width)]
    image = cv2.resize(crop, (view.width, view.height), interpolation=cv2.INTER_AREA)
    return CameraFrame(k * NS, image, view)


def started(config: CamShiftConfig | None = None, view: View | None = None) -> CamShiftTracker:
    tracker = CamShiftTracker(config)
    first = frame(0, scene_with_target(0), view)
    assert tracker.select_region(true_box(*target_position(0)), first) is None
    return tracker


def test_it_is_a_registered_seeded_detector():
    method = DETECTORS.get("camshift")
    detector = method.build(method.defaults())
    assert isinstance(detector, SeededDetector)
    assert method.defaults()["hue_bins"] == 32
    assert (method.defaults()["v_min"], method.defaults()["v_max"]) == (10, 256)
    assert method.defaults()["s_min"] == 30


def test_follows_a_walking_target_at_iou_half_on_a_static_camera():
    tracker = started()
    ious = []
    for k in range(1, 60):
        detection = tracker.process(frame(k, scene_with_target(k)))
        assert len(detection.blobs) == 1 and detection.target_present
        ious.append(detection.blobs[0].bbox.iou(true_box(*target_position(k))))
    assert min(ious) >= 0.5, f"worst IoU {min(ious):.2f}"
    assert np.mean(ious) >= 0.7


def test_boxes_are_in_scene_coordinates_on_a_panning_zoomed_out_view():
    """The camera follows the target with a lag and shows 240x180 scene px in a 120x90 image."""
    view = View(Rect(0.0, 90.0, 240.0, 180.0), 120, 90)
    tracker = started(view=view)
    for k in range(1, 60):
        cx, cy = target_position(k - 3)  # the pan-tilt unit lags three frames behind
        x = min(max(cx - 120.0, 0.0), SCENE_W - 240.0)
        y = min(max(cy - 90.0, 0.0), SCENE_H - 180.0)
        view = View(Rect(round(x), round(y), 240.0, 180.0), 120, 90)
        detection = tracker.process(frame(k, scene_with_target(k), view))
        assert len(detection.blobs) == 1, f"lost at frame {k}"
        iou = detection.blobs[0].bbox.iou(true_box(*target_position(k)))
        assert iou >= 0.5, f"frame {k}: IoU {iou:.2f}"


def test_an_empty_back_projection_is_a_miss_not_a_window_at_the_origin():
    tracker = started()
    tracker.process(frame(1, scene_with_target(1)))
    detection = tracker.process(frame(2, scene_with_target(2, visible=False)))
    assert detection.blobs == [] and not detection.target_present and detection.compared
    assert tracker.misses == 1
    assert tracker.window is not None and tracker.window.x > 50  # kept, not moved to (0, 0)


def test_lost_after_consecutive_misses_then_reacquired_anywhere_in_the_view():
    config = CamShiftConfig(lost_after=3)
    tracker = started(config)
    for k in range(1, 5):
        assert tracker.process(frame(k, scene_with_target(k, visible=False))).blobs == []
    assert not tracker.tracking
    reappears = (380.0, 260.0)  # far from where it vanished
    detection = tracker.process(frame(5, scene_with_target(5, position=reappears)))
    assert len(detection.blobs) == 1 and tracker.tracking
    assert detection.blobs[0].bbox.iou(true_box(*reappears)) >= 0.5


def test_a_jump_beyond_the_search_region_is_found_when_the_prediction_guides_the_window():
    jump = (300.0, 120.0)
    unguided = started()
    assert unguided.process(frame(1, scene_with_target(1, position=jump))).blobs == []
    guided = started()
    guided.guide(jump)
    blobs = guided.process(frame(1, scene_with_target(1, position=jump))).blobs
    assert len(blobs) == 1 and blobs[0].bbox.iou(true_box(*jump)) >= 0.5


def test_a_window_spreading_over_a_large_region_of_the_target_colour_is_a_miss():
    tracker = started(CamShiftConfig(max_size_ratio=2.0))
    side = math.sqrt(4 * AXES[0] * AXES[1])
    reported = []
    for k in range(1, 8):
        scene = scene_with_target(k)
        scene[100:300, 20:200] = TARGET_BGR  # the target walks in front of a red wall
        reported += tracker.process(frame(k, scene)).blobs
    assert len(reported) < 7, "the wall was reported as the target every frame"
    for blob in reported:
        assert math.sqrt(blob.bbox.width * blob.bbox.height) <= 2.0 * side * 1.3


def test_the_oriented_box_follows_a_tilted_target():
    tracker = CamShiftTracker()
    scene = background()
    cv2.ellipse(scene, (240, 180), (12, 40), 30, 0, 360, TARGET_BGR, -1)
    first = CameraFrame(NS, scene, View.identity(SCENE_W, SCENE_H))
    assert tracker.select_region(Rect(200, 140, 80, 80), first) is None
    blob = tracker.process(CameraFrame(2 * NS, scene, first.view)).blobs[0]
    assert blob.oriented_size is not None
    long_side = max(blob.oriented_size)
    assert long_side == pytest.approx(80, rel=0.15)
    assert blob.bbox.iou(Rect(200, 140, 80, 80)) >= 0.9  # the box reported is the one selected
    box = OrientedBox(240.0, 180.0, *blob.oriented_size, blob.angle)
    assert box.bounds.iou(Rect.from_center(240, 180, 2 * 40 * 0.5 + 2 * 12 * 0.866, 80)) > 0.6
    # the long axis points 30 degrees past the vertical (120 degrees from x, or its opposite)
    long_axis = (
        blob.angle if blob.oriented_size[0] >= blob.oriented_size[1] else blob.angle + math.pi / 2
    )
    assert math.cos(2 * (long_axis - math.radians(120))) > math.cos(math.radians(20))


@pytest.mark.parametrize(
    ("region", "reason"),
    [
        (Rect(10, 10, 0, 20), "positive size"),
        (Rect(1000, 1000, 20, 20), "outside the camera view"),
        (Rect(200, 130, 30, 30), "coloured target"),  # plain grey street
    ],
)
def test_a_bad_selection_is_refused_with_its_reason_and_changes_nothing(region, reason):
    tracker = started()
    before = tracker.window
    scene = background()
    scene[130:160, 200:230] = 120
    message = tracker.select_region(region, frame(0, scene))
    assert message is not None and reason in message
    assert tracker.window == before and tracker.model is not None


def test_a_grey_image_is_refused_with_a_reason():
    tracker = started()
    grey = CameraFrame(NS, np.zeros((SCENE_H, SCENE_W), np.uint8), View.identity(SCENE_W, SCENE_H))
    with pytest.raises(ValueError, match="colour"):
        tracker.process(grey)


def test_reset_restarts_from_the_selection_and_keeps_the_model():
    tracker = started()
    for k in range(1, 20):
        tracker.process(frame(k, scene_with_target(k)))
    tracker.reset()
    assert tracker.window == tracker.selection
    blobs = tracker.process(frame(1, scene_with_target(1))).blobs
    assert len(blobs) == 1


def test_reconfigure_rebuilds_the_model_from_the_selection():
    tracker = started()
    tracker.reconfigure(CamShiftConfig(hue_bins=16))
    assert tracker.model is not None and tracker.model.histogram.size == 16
    tracker.reconfigure(CamShiftConfig(s_min=250))  # nothing of the coat is that saturated
    assert tracker.model is None
    assert tracker.process(frame(1, scene_with_target(1))).blobs == []
    with pytest.raises(ValueError, match="v_min"):
        CamShiftTracker(CamShiftConfig(v_min=200, v_max=100))


def test_background_weights_are_comaniciu_min_ratio():
    """Bin u weighs min(o*/o_u, 1), o* the smallest non-zero count around the selection; a colour
    absent around it keeps weight 1."""
    from tracker_msgs_py.histograms import background_weights

    around = np.array([[0.0], [10.0], [40.0], [5.0]], np.float32)
    assert background_weights(around)[:, 0] == pytest.approx([1.0, 0.5, 0.125, 1.0])
    assert background_weights(np.zeros((3, 1), np.float32))[:, 0] == pytest.approx([1, 1, 1])


def test_a_target_sharing_a_colour_with_its_surroundings_is_followed_by_its_own_colour():
    """A red coat over grey trousers on a grey street: the plain hue histogram also holds the
    street's faint hues, the background-weighted one lights the coat; the box reported is still
    the whole selected box (coat and trousers), carried by the coat's colours."""

    def picture(k: int) -> np.ndarray:
        scene = background()
        cx, cy = target_position(k)
        x0, y0 = round(cx) - AXES[0], round(cy) - AXES[1]
        scene[y0 : y0 + AXES[1], x0 : x0 + 2 * AXES[0]] = TARGET_BGR  # the coat, upper half
        scene[y0 + AXES[1] : y0 + 2 * AXES[1], x0 : x0 + 2 * AXES[0]] = (110, 112, 115)  # trousers
        return scene

    tracker = CamShiftTracker()
    assert tracker.select_region(true_box(*target_position(0)), frame(0, picture(0))) is None
    ious = []
    for k in range(1, 60):
        blobs = tracker.process(frame(k, picture(k))).blobs
        ious.append(blobs[0].bbox.iou(true_box(*target_position(k))) if blobs else 0.0)
    assert min(ious) >= 0.7


def test_a_handed_over_box_replaces_the_target_only_when_its_colours_match_better():
    """While tracking, CamShift drifted onto a red box standing where the person stood (the
    person, red coat and blue trousers, walked on). The person's box, offered again by the motion
    tracker, matches the model better than the drifted-to red box: taken. A grey passer-by's box
    matches worse: refused. A box over the tracked one is the same target: refused."""
    coat, trousers = TARGET_BGR, (160, 60, 30)

    def person(scene: np.ndarray, box: Rect) -> None:
        x, y, w, h = (round(v) for v in (box.x, box.y, box.width, box.height))
        scene[y : y + h // 2, x : x + w] = coat
        scene[y + h // 2 : y + h, x : x + w] = trousers

    start = true_box(240, 180)
    first = background()
    person(first, start)
    tracker = CamShiftTracker()
    assert tracker.select_region(start, frame(0, first)) is None
    later = background()
    red_box = Rect(start.x, start.y, start.width, start.height / 2)  # the coat's colour only
    later[
        round(red_box.y) : round(red_box.y + red_box.height),
        round(red_box.x) : round(red_box.x + red_box.width),
    ] = coat
    walked_on = true_box(380, 180)
    person(later, walked_on)
    grey = true_box(100, 180)
    later[
        round(grey.y) : round(grey.y + grey.height), round(grey.x) : round(grey.x + grey.width)
    ] = (120, 122, 125)
    image = frame(1, later)
    tracker.last_box = red_box  # where CamShift drifted
    assert tracker.hand_over(start, image) == "it is the tracked target"
    assert "match the model" in tracker.hand_over(grey, image)
    assert tracker.similarity(walked_on, image) > tracker.similarity(red_box, image)
    assert tracker.hand_over(walked_on, image) is None
    assert tracker.selection == walked_on


def test_a_target_that_does_not_stand_out_from_its_surroundings_is_refused():
    """A box on a red wall (a red coat in front of it): the back-projection is as strong around it
    as on it, so CamShift would slide off; the selection is refused with the reason."""
    scene = background()
    scene[100:300, 150:350] = TARGET_BGR  # the wall, the coat's own colour
    tracker = CamShiftTracker()
    reason = tracker.select_region(true_box(250.0, 200.0), frame(0, scene))
    assert reason is not None and "stand out" in reason
    assert tracker.model is None
    unchecked = CamShiftTracker(CamShiftConfig(min_contrast=0.0))
    assert unchecked.select_region(true_box(250.0, 200.0), frame(0, scene)) is None
