"""The person plug-in (NanoDet): the model file as shipped, its decoding, the runtimes, and what
happens when the model cannot be loaded."""

from __future__ import annotations

import hashlib
import shutil

import numpy as np
import pytest
from ros_process import RosProcess

from tracker_detect.detector import CameraFrame
from tracker_detect.person import person
from tracker_detect.person.person import ModelUnavailableError, PersonConfig, PersonModel
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect


def test_the_shipped_models_match_their_checksums_and_licence():
    folder = person.shipped_model().parent
    sums = person.known_checksums(folder)
    assert set(sums) == {*person.MODEL_FILES.values(), "centernet.onnx"}
    for name, digest in sums.items():
        assert hashlib.sha256((folder / name).read_bytes()).hexdigest() == digest
    licence = (folder / "LICENSE").read_text()
    assert "MIT License" in licence and "Apache License 2.0" in licence


def test_nanodet_grids_follow_the_input_size():
    """Every stride's cells (scores and the 4 x 11 side bins) for any multiple of 32."""
    model = PersonModel(PersonConfig())
    for height, width in ((256, 256), (320, 416), (96, 160)):
        blob = np.zeros((1, 3, height, width), np.float32)
        outputs = model.runtime.run(blob)
        cells = sorted((v.shape[1], v.shape[2]) for v in outputs.values())
        expected = sorted(
            (height // s * (width // s), columns) for s in (8, 16, 32) for columns in (80, 44)
        )
        assert cells == expected


def test_decoding_puts_a_box_where_the_bins_say():
    """One confident cell at stride 16, row 3, col 5 of a 128 x 128 input, sides 2, 1, 3, 4
    strides (all bins' weight on one distance): the box is the cell centre minus / plus those."""
    model = PersonModel(PersonConfig())
    outputs = {}
    for stride, (scores, sides) in zip(
        (8, 16, 32), (("a", "b"), ("c", "d"), ("e", "f")), strict=True
    ):
        n = (128 // stride) ** 2
        outputs[scores] = np.zeros((1, n, 80), np.float32)
        outputs[sides] = np.full((1, n, 44), -50.0, np.float32)
    cell = 3 * 8 + 5
    outputs["c"][0, cell, 0] = 0.9
    for side, distance in enumerate((2, 1, 3, 4)):
        outputs["d"][0, cell, side * 11 + distance] = 50.0
    boxes = model.decode(outputs, 128, 128)
    centre = np.array([5.5 * 16, 3.5 * 16])
    expected = [centre[0] - 32, centre[1] - 16, centre[0] + 48, centre[1] + 64, 0.9]
    np.testing.assert_allclose(boxes, [expected], atol=1e-3)


def test_overlapping_boxes_are_one_person_and_side_by_side_two():
    boxes = np.array([[0, 0, 10, 30, 0.9], [1, 0, 11, 31, 0.8], [12, 0, 22, 30, 0.7]], np.float32)
    kept = person.non_maximum_suppression(boxes, 0.5)
    assert kept.tolist() == [0, 2]


def test_opencv_dnn_gives_the_outputs_onnxruntime_gives():
    rng = np.random.default_rng(1)
    image = rng.integers(0, 255, (264, 264, 3), dtype=np.uint8)
    a = PersonModel(PersonConfig(score_threshold=0.05, precision="float32"))
    b = PersonModel(PersonConfig(score_threshold=0.05, precision="float32", runtime="opencv"))
    blob, _ = a.blob(image)
    outputs_a, outputs_b = a.runtime.run(blob), b.runtime.run(blob)
    for name, value in outputs_a.items():
        np.testing.assert_allclose(outputs_b[name], value, atol=1e-4)


def test_opencv_dnn_finds_the_people_onnxruntime_finds_with_the_int8_model(vtest_clip):
    """The two runtimes' int8 arithmetic rounds differently: the same people, within a pixel."""
    frame, _ = next(annotated_frames(vtest_clip))
    view = frame[100:400, 200:600]
    a = PersonModel(PersonConfig(precision="int8")).detect(view)
    b = PersonModel(PersonConfig(precision="int8", runtime="opencv")).detect(view)
    assert len(a) >= 2 and len(a) == len(b)
    np.testing.assert_allclose(b[:, :4], a[:, :4], atol=1.5)
    np.testing.assert_allclose(b[:, 4], a[:, 4], atol=0.03)


def test_the_int8_model_finds_the_people_the_float_model_finds(vtest_clip):
    """On 80 views of vtest.avi as the camera sees them (264 x 198 px, zoom 1-2.9), the
    quantised model's boxes are the float model's: >= 90 % of them within IoU 0.7."""
    import cv2

    from tracker_msgs_py.geometry import corner_iou_matrix

    exact = PersonModel(PersonConfig(precision="float32", score_threshold=0.35))
    quantised = PersonModel(PersonConfig(precision="int8", score_threshold=0.35))
    rng = np.random.default_rng(1)
    found = matched = 0
    for frame, _ in annotated_frames(vtest_clip, every=10):
        w = int(768 / rng.uniform(1.0, 2.9))
        h = w * 3 // 4
        x, y = rng.integers(0, 768 - w + 1), rng.integers(0, 576 - h + 1)
        view = cv2.resize(frame[y : y + h, x : x + w], (264, 198), interpolation=cv2.INTER_AREA)
        a, b = exact.detect(view), quantised.detect(view)
        found += len(a)
        if len(a) and len(b):
            matched += int((corner_iou_matrix(a[:, :4], b[:, :4]).max(axis=1) >= 0.7).sum())
    assert found > 150
    assert matched >= 0.9 * found, f"{matched} of {found}"


def test_boxes_come_out_in_scene_coordinates_of_the_view():
    detector = person.PersonDetector(PersonConfig(score_threshold=0.0, nms_iou=0.3))
    image = np.full((128, 128, 3), 128, np.uint8)
    view = View(Rect(1000.0, 500.0, 256.0, 256.0), 128, 128)  # 2 scene px per image px
    detection = detector.process(CameraFrame(1, image, view))
    assert detection.compared and detection.blobs
    for blob in detection.blobs:
        assert blob.bbox.x >= 1000.0 and blob.bbox.x + blob.bbox.width <= 1256.0 + 1e-6
        assert blob.bbox.y >= 500.0 and blob.bbox.y + blob.bbox.height <= 756.0 + 1e-6


def test_a_damaged_model_file_is_named_in_one_line(tmp_path):
    copy = tmp_path / "nanodet.onnx"
    shutil.copy(person.shipped_model(), copy)
    (tmp_path / "SHA256SUMS").write_text((person.shipped_model().parent / "SHA256SUMS").read_text())
    data = bytearray(copy.read_bytes())
    data[5000] ^= 0xFF
    copy.write_bytes(bytes(data))
    with pytest.raises(ModelUnavailableError, match="damaged"):
        PersonModel(PersonConfig(model_path=str(copy)))
    with pytest.raises(ModelUnavailableError, match="No such file"):
        PersonModel(PersonConfig(model_path=str(tmp_path / "missing.onnx")))


@pytest.mark.ros
@pytest.mark.parametrize("case", ["missing", "not_a_model"])
def test_the_detector_node_stops_at_start_up_with_the_cause(tmp_path, case):
    path = tmp_path / "model.onnx"
    if case == "not_a_model":
        path.write_bytes(b"this is not ONNX")
    node = RosProcess(
        "tracker_detect",
        "detector",
        log_dir=tmp_path,
        params={"method": "person", "model_path": str(path)},
    )
    try:
        code = node.wait(timeout=30)
    finally:
        node.kill()
    output = node.output()
    assert code == 2, output
    assert "the person detector cannot start" in output and str(path) in output
    assert "Traceback" not in output and output.count("[FATAL]") == 1


def annotated_frames(video, every: int = 40):
    """Every `every`-th frame of vtest.avi (20 of its 795) with its reviewed ground truth."""
    from tracker_ptz_sim.bringup.benchmark import CLIPS
    from tracker_ptz_sim.simulation.frame_sources import video_frames
    from tracker_ptz_sim.simulation.ground_truth import read_tracks

    truth = read_tracks(CLIPS["vtest"].gt)
    for index, frame in enumerate(video_frames(video)):
        if (index + 1) % every == every // 2:
            yield frame, list(truth.in_frame(index + 1).values())


@pytest.mark.parametrize("precision", list(person.MODEL_FILES))
def test_the_person_model_finds_the_annotated_people(vtest_clip, precision):
    """On 20 annotated frames of vtest.avi, at the camera's scale (the whole 768 px frame at a 768
    px input: people as large as in a 264 px view at the default 256 px input), the shipped model
    and defaults find >= 85 % of the people at least half visible, >= 90 % of its boxes right
    (IoU >= 0.5; boxes on people less visible than that count neither way)."""
    from box_scores import BoxScore

    from tracker_msgs_py.geometry import corner_iou_matrix

    model = PersonModel(PersonConfig(input_size=768, precision=precision))
    score = BoxScore()
    frames = 0
    for frame, people in annotated_frames(vtest_clip):
        frames += 1
        found = model.detect(frame)
        hidden = np.array([p.corners for p in people if p.visibility < 0.5]).reshape(-1, 4)
        if len(hidden) and len(found):
            found = found[corner_iou_matrix(found, hidden).max(axis=1) < 0.5]
        counted = [Rect(p.x, p.y, p.w, p.h) for p in people if p.visibility >= 0.5]
        score.add(counted, [Rect(b[0], b[1], b[2] - b[0], b[3] - b[1]) for b in found])
    assert frames == 20 and score.objects > 100
    assert score.recall >= 0.85, f"recall {score.recall:.3f}"
    assert score.precision >= 0.9, f"precision {score.precision:.3f}"


def test_without_onnxruntime_the_cause_and_the_fallback_are_named(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # import onnxruntime now fails
    person._load.cache_clear()
    try:
        with pytest.raises(ModelUnavailableError, match="onnxruntime is not installed.*opencv"):
            PersonModel(PersonConfig(threads=3))  # a thread count not loaded before
        assert PersonModel(PersonConfig(runtime="opencv")).runtime.kind == "opencv"
    finally:
        person._load.cache_clear()
