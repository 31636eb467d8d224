"""The annotation assistant's detector: two person models, test-time augmentation, fusion (no rclpy).

Offline, so slow is fine: per frame
- NanoDet (`tracker_detect.person.person.PersonModel`) on the whole frame at 1x, 1.5x and 2x its size,
  each also mirrored;
- CenterNet (`models/centernet.onnx`, RGB 0-255, a fixed 512 x 512 input) on overlapping
  512 px tiles of the frame at 1x and 2x, each also mirrored;
- every box of every pass fused by weighted box fusion (`fuse`): boxes of different passes that
  overlap by IoU >= `fusion_iou` are one person, placed at their score-weighted mean; its score is
  the sum of its boxes' scores over the number of passes, so a person every pass finds scores
  near the models' own confidence and one a single pass finds, a fraction of it.

The frames' people then go to `linking` (tracks) and are reviewed by eye (`corrections`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from tracker_detect.person.person import (
    PersonConfig,
    PersonModel,
    non_maximum_suppression,
    verified_model_bytes,
)
from tracker_msgs_py.geometry import corner_iou_matrix
from tracker_msgs_py.package_files import package_data

CENTERNET_NAME = "centernet.onnx"
CENTERNET_SIZE = 512  # px, its fixed input


@dataclass(frozen=True)
class AssistantConfig:
    nanodet_scales: tuple[float, ...] = (1.0, 1.5, 2.0)  # whole-frame magnifications
    centernet_scales: tuple[float, ...] = (1.0, 2.0)  # magnifications tiled into 512 px tiles
    tile_overlap: float = 0.25  # of a tile's side, shared with its neighbour
    pass_threshold: float = 0.2  # a pass's boxes below this score are not fused
    fusion_iou: float = 0.55  # boxes of different passes overlapping this much are one person
    threads: int = 2


class CenterNet:
    """The package's CenterNet: COCO boxes (x0, y0, x1, y1, score, class) for one 512 px tile."""

    def __init__(self, threads: int) -> None:
        import onnxruntime as ort

        path = package_data("tracker_detect", "models") / CENTERNET_NAME
        options = ort.SessionOptions()
        options.intra_op_num_threads = threads
        options.log_severity_level = 3
        self.session = ort.InferenceSession(
            verified_model_bytes(path), options, providers=["CPUExecutionProvider"]
        )
        self.input_name = self.session.get_inputs()[0].name

    def people(self, tile: np.ndarray, threshold: float) -> np.ndarray:
        """(N, 5) person boxes (x0, y0, x1, y1, score) in a 512 x 512 BGR tile's px."""
        rgb = np.ascontiguousarray(tile[:, :, ::-1], np.float32)[None]
        (detections,) = self.session.run(["tower_0/detections"], {self.input_name: rgb})
        d = detections[0]
        keep = (d[:, 5] == 0) & (d[:, 4] >= threshold)
        people: np.ndarray = d[keep, :5].astype(np.float32)
        return people


def _tiles(width: int, height: int, size: int, overlap: float) -> Iterator[tuple[int, int]]:
    """Top-left corners of `size` px tiles covering a width x height image with `overlap`."""

    def starts(length: int) -> list[int]:
        if length <= size:
            return [0]
        count = math.ceil((length - size) / (size * (1 - overlap))) + 1
        return [round(i * (length - size) / (count - 1)) for i in range(count)]

    for y in starts(height):
        for x in starts(width):
            yield x, y


def _mirrored(boxes: np.ndarray, width: int) -> np.ndarray:
    out = boxes.copy()
    out[:, 0], out[:, 2] = width - boxes[:, 2], width - boxes[:, 0]
    return out


class Assistant:
    """Fused person boxes of one frame (see the module docstring)."""

    def __init__(self, config: AssistantConfig | None = None) -> None:
        self.config = config or AssistantConfig()
        c = self.config
        self.nanodet = {
            s: PersonModel(
                PersonConfig(
                    input_size=32 * round(768 * s / 32),
                    score_threshold=c.pass_threshold,
                    threads=c.threads,
                )
            )
            for s in c.nanodet_scales
        }
        self.centernet = CenterNet(c.threads)

    @property
    def passes(self) -> int:
        return 2 * (len(self.config.nanodet_scales) + len(self.config.centernet_scales))

    def frame_passes(self, frame: np.ndarray) -> list[np.ndarray]:
        """Each pass's person boxes (x0, y0, x1, y1, score) in frame px."""
        height, width = frame.shape[:2]
        found = []
        for flip in (False, True):
            image = frame[:, ::-1] if flip else frame
            for scale in self.config.nanodet_scales:
                model = self.nanodet[scale]
                magnified = cv2.resize(
                    image, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC
                )
                boxes = model.detect(magnified)
                boxes[:, :4] /= scale
                found.append(_mirrored(boxes, width) if flip else boxes)
            for scale in self.config.centernet_scales:
                boxes = self._centernet(image, scale)
                found.append(_mirrored(boxes, width) if flip else boxes)
        return found

    def _centernet(self, image: np.ndarray, scale: float) -> np.ndarray:
        c = self.config
        magnified = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)
        h, w = magnified.shape[:2]
        if h < CENTERNET_SIZE or w < CENTERNET_SIZE:  # pad a small image to one tile
            pad = np.zeros((max(h, CENTERNET_SIZE), max(w, CENTERNET_SIZE), 3), np.uint8)
            pad[:h, :w] = magnified
            magnified = pad
        boxes = []
        for x, y in _tiles(w, h, CENTERNET_SIZE, c.tile_overlap):
            tile = np.ascontiguousarray(magnified[y : y + CENTERNET_SIZE, x : x + CENTERNET_SIZE])
            found = self.centernet.people(tile, c.pass_threshold)
            found[:, [0, 2]] += x
            found[:, [1, 3]] += y
            boxes.append(_drop_cut(found, x, y, w, h))
        merged = np.concatenate(boxes) if boxes else np.zeros((0, 5), np.float32)
        merged = merged[non_maximum_suppression(merged, 0.6)] if len(merged) else merged
        merged[:, :4] /= scale
        return merged

    def detect(self, frame: np.ndarray, threshold: float = 0.0) -> np.ndarray:
        """(N, 5) fused person boxes (x0, y0, x1, y1, fused score) of one BGR frame."""
        fused = fuse(self.frame_passes(frame), self.config.fusion_iou)
        return fused[fused[:, 4] >= threshold]


def _drop_cut(boxes: np.ndarray, x: int, y: int, w: int, h: int, margin: float = 4.0) -> np.ndarray:
    """Boxes of a tile that its inner edges cut (a neighbouring tile sees the whole person)."""
    right, bottom = x + CENTERNET_SIZE, y + CENTERNET_SIZE
    cut = (
        ((boxes[:, 0] <= x + margin) & (x > 0))
        | ((boxes[:, 1] <= y + margin) & (y > 0))
        | ((boxes[:, 2] >= right - margin) & (right < w))
        | ((boxes[:, 3] >= bottom - margin) & (bottom < h))
    )
    return boxes[~cut]


def fuse(passes: list[np.ndarray], iou: float) -> np.ndarray:
    """Weighted box fusion of several passes' (x0, y0, x1, y1, score) boxes: best first, each box
    joins the cluster whose fused box it overlaps most (IoU >= `iou`) unless that cluster already
    holds a box of its pass; a cluster's box is the score-weighted mean of its boxes and its score
    the sum of their scores / len(passes)."""
    tagged = [(box, k) for k, boxes in enumerate(passes) for box in boxes]
    tagged.sort(key=lambda item: -float(item[0][4]))
    clusters: list[tuple[np.ndarray, float, set[int]]] = []  # weighted sum, weight, passes
    fused = np.zeros((0, 5), np.float32)
    for box, k in tagged:
        best, best_iou = -1, iou
        if len(fused):
            overlaps = corner_iou_matrix(box[None], fused)[0]
            for j in np.argsort(-overlaps):
                if overlaps[j] < best_iou:
                    break
                if k not in clusters[j][2]:
                    best = int(j)
                    break
        score = float(box[4])
        if best < 0:
            clusters.append((box[:4] * score, score, {k}))
            fused = np.vstack([fused, np.append(box[:4], score)[None]]).astype(np.float32)
        else:
            total, weight, members = clusters[best]
            members.add(k)
            clusters[best] = (total + box[:4] * score, weight + score, members)
            fused[best, :4] = clusters[best][0] / clusters[best][1]
    if not clusters:
        return fused
    fused[:, 4] = [weight / len(passes) for _, weight, _ in clusters]
    return fused[np.argsort(-fused[:, 4], kind="stable")]
