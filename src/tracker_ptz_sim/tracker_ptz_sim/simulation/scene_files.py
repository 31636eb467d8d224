"""A scene's files (no rclpy): :func:`write_scene` and :func:`load_scene` for every generator's
scenes (:mod:`~tracker_ptz_sim.simulation.scenes`' objects, the street scenes and the small-object
scenes; ``scene.json`` names the ``generator``).

A lossless FFV1 video (or a PNG folder when OpenCV cannot write FFV1), MOTChallenge ``gt/gt.txt``
(``frame,id,x,y,w,h,conf,class,visibility`` with 1-based frames and x, y in the pixel convention of
:mod:`~tracker_ptz_sim.simulation.scenes`), 16-bit label PNGs in ``masks/``, ``seqinfo.ini`` and
``scene.json`` (the config and jitter, to load the scene back exactly). Apart from the generators,
which it reads the configs of: a generator imports :mod:`scenes` for the scene's types only.
"""

from __future__ import annotations

import configparser
import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from functools import partial
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from tracker_ptz_sim.simulation.scenes import GroundTruthBox, Scene, SceneConfig
from tracker_ptz_sim.simulation.small_objects import SmallObjectsConfig
from tracker_ptz_sim.simulation.street import StreetConfig

VIDEO_NAME = "video.avi"
FRAMES_DIR = "frames"  # PNG fallback when FFV1 cannot be written
MASKS_DIR = "masks"
GT_PATH = "gt/gt.txt"
META_NAME = "scene.json"


@dataclass(frozen=True)
class ScenePaths:
    """Where :func:`write_scene` put each part of a scene."""

    root: Path
    video: Path  # the video file, or the PNG folder when FFV1 was not available
    gt: Path
    masks: Path
    seqinfo: Path
    meta: Path


def _write_video(frames: np.ndarray, fps: float, root: Path) -> Path:
    """FFV1 in AVI (bit-exact through OpenCV's FFmpeg backend), else a PNG folder."""
    path = root / VIDEO_NAME
    height, width = frames.shape[1:3]
    fourcc = cv2.VideoWriter_fourcc(*"FFV1")  # type: ignore[attr-defined]  # missing from cv2's stubs
    writer = cv2.VideoWriter(str(path), fourcc, fps, (width, height))
    if writer.isOpened():
        for frame in frames:
            writer.write(frame)
        writer.release()
        return path
    writer.release()
    path.unlink(missing_ok=True)
    folder = root / FRAMES_DIR
    folder.mkdir(parents=True, exist_ok=True)
    for n, frame in enumerate(frames):
        cv2.imwrite(str(folder / f"{n + 1:06d}.png"), frame)
    return folder


def write_scene(scene: Scene, out_dir: str | Path) -> ScenePaths:
    """Write ``scene`` into ``out_dir`` (created if needed); layout in the module docstring."""
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    video = _write_video(scene.frames, scene.fps, root)
    gt = root / GT_PATH
    gt.parent.mkdir(parents=True, exist_ok=True)
    with gt.open("w") as f:
        for frame_boxes in scene.boxes:
            for b in frame_boxes:
                row = (
                    b.frame + 1,
                    b.object_id,
                    b.x,
                    b.y,
                    b.width,
                    b.height,
                    b.conf,
                    1,
                    b.visibility,
                )
                f.write(",".join(f"{v:g}" for v in row) + "\n")
    masks = root / MASKS_DIR
    masks.mkdir(exist_ok=True)
    if scene.labels.max(initial=0) > np.iinfo(np.uint16).max:
        raise ValueError("object ids above 65535 cannot be stored in 16-bit mask PNGs")
    for n, label in enumerate(scene.labels):
        cv2.imwrite(str(mask_path(root, n + 1)), label.astype(np.uint16))
    seqinfo = root / "seqinfo.ini"
    info = configparser.ConfigParser()
    info.optionxform = str  # type: ignore[assignment,method-assign]  # keep camelCase keys (documented use)
    info["Sequence"] = {
        "name": root.name,
        "imDir": video.name,
        "frameRate": f"{scene.fps:g}",
        "seqLength": str(scene.num_frames),
        "imWidth": str(scene.frames.shape[2]),
        "imHeight": str(scene.frames.shape[1]),
        "imExt": ".png" if video.is_dir() else video.suffix,
    }
    with seqinfo.open("w") as f:
        info.write(f)
    meta = root / META_NAME
    meta.write_text(
        json.dumps(
            {
                "generator": scene.config.generator if scene.config else None,
                "fps": scene.fps,
                "num_frames": scene.num_frames,
                "video": video.name,
                "config": asdict(scene.config) if scene.config else None,
                "jitter": scene.jitter.tolist(),
            },
            indent=1,
        )
    )
    return ScenePaths(root, video, gt, masks, seqinfo, meta)


def _read_frames(path: Path) -> np.ndarray:
    images: list[np.ndarray | None] = []
    if path.is_dir():
        images = [cv2.imread(str(p), cv2.IMREAD_COLOR) for p in sorted(path.glob("*.png"))]
    else:
        capture = cv2.VideoCapture(str(path))
        while True:
            ok, image = capture.read()
            if not ok:
                break
            images.append(image)
        capture.release()
    readable = [image for image in images if image is not None]
    if not readable or len(readable) < len(images):
        raise ValueError(f"{path}: no readable frames")
    return np.stack(readable)


def _config_type(
    generator: str | None,
) -> type[SceneConfig] | type[StreetConfig] | type[SmallObjectsConfig]:
    if generator in (None, SceneConfig.generator):
        return SceneConfig
    if generator == "street":
        return StreetConfig
    if generator == "small_objects":
        return SmallObjectsConfig
    raise ValueError(f"unknown scene generator {generator!r}")


def _config_from_dict(
    data: dict, kind: type[SceneConfig] | type[StreetConfig] | type[SmallObjectsConfig]
) -> Any:
    kwargs: dict[str, Any] = {}
    for f in fields(kind):
        if f.name in data:
            value = data[f.name]
            kwargs[f.name] = tuple(value) if isinstance(value, list) else value
    return kind(**kwargs)


def _read_mask(path: Path, dtype: type[np.integer]) -> np.ndarray:
    mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if mask is None:
        raise ValueError(f"{path}: missing or unreadable label mask")
    return mask.astype(dtype)


def mask_path(root: Path, frame: int) -> Path:
    """The label image of a scene's 1-based `frame` (pixel value = object id, 0 = background)."""
    return root / MASKS_DIR / f"{frame:06d}.png"


def read_label(root: Path, frame: int) -> np.ndarray:
    """The label image of a scene's 1-based `frame` as int64."""
    return _read_mask(mask_path(root, frame), np.int64)


def label_reader(root: Path) -> Callable[[int], np.ndarray] | None:
    """`read_label` for the scene directory `root`, or None when it has no label masks."""
    return partial(read_label, root) if mask_path(root, 1).is_file() else None


def load_scene(directory: str | Path) -> Scene:
    """Read back a scene written by :func:`write_scene` (frames, labels, boxes, jitter, fps);
    labels are int32, or uint16 for street and small-object scenes (as generated)."""
    root = Path(directory)
    meta_path = root / META_NAME
    if not meta_path.is_file():
        raise FileNotFoundError(f"{root}: not a scene directory (no {META_NAME})")
    meta = json.loads(meta_path.read_text())
    frames = _read_frames(root / meta["video"])
    n = frames.shape[0]
    if n != meta["num_frames"]:
        raise ValueError(f"{root}: {n} frames in the video, {meta['num_frames']} expected")
    kind = _config_type(meta.get("generator"))
    dtype = np.int32 if kind.generator == SceneConfig.generator else np.uint16
    labels = np.stack([_read_mask(mask_path(root, i + 1), dtype) for i in range(n)])
    boxes: list[list[GroundTruthBox]] = [[] for _ in range(n)]
    for line in (root / GT_PATH).read_text().splitlines():
        if not line.strip():
            continue
        frame, obj, x, y, w, h, conf, _cls, vis = line.split(",")
        k = int(frame) - 1
        boxes[k].append(
            GroundTruthBox(
                k, int(obj), float(x), float(y), float(w), float(h), float(vis), int(float(conf))
            )
        )
    config = _config_from_dict(meta["config"], kind) if meta.get("config") else None
    return Scene(
        frames,
        float(meta["fps"]),
        labels,
        boxes,
        np.asarray(meta["jitter"], np.int64).reshape(n, 2),
        config,
    )


def scene_video(directory: str | Path) -> Path:
    """The video (or PNG folder) of a scene written by :func:`write_scene`."""
    root = Path(directory)
    meta = json.loads((root / META_NAME).read_text())
    video: Path = root / meta["video"]
    return video
