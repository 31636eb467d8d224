"""Ground-truth and track tables in MOTChallenge's text format (no rclpy).

`Tracks` is per id, per frame, a person's `Box`; `Detections` per frame the boxes found in it, no
ids. Files: `frame, id, x, y, w, h, score, class, visibility, ...`, frames numbered from 1, (x, y)
the top-left corner in px; `seqinfo.ini` holds a clip's name, frame rate, length and size. The
annotation tool (`annotation`) writes them, the real-people scenes (`real_people`) read them.
"""

from __future__ import annotations

import configparser
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np


@dataclass(frozen=True)
class Box:
    x: float
    y: float
    w: float
    h: float
    score: float = 1.0
    visibility: float = 1.0

    @property
    def corners(self) -> np.ndarray:
        return np.array([self.x, self.y, self.x + self.w, self.y + self.h])

    @classmethod
    def from_corners(cls, c: np.ndarray, score: float = 1.0) -> Box:
        return cls(float(c[0]), float(c[1]), float(c[2] - c[0]), float(c[3] - c[1]), score)


@dataclass
class Detections:
    """Per frame (from 1), the boxes found in it."""

    by_frame: dict[int, list[Box]] = field(default_factory=dict)

    def frames(self) -> set[int]:
        return set(self.by_frame)


@dataclass
class Tracks:
    """Per id, per frame (from 1), the person's box."""

    by_id: dict[int, dict[int, Box]] = field(default_factory=dict)

    def ids(self) -> list[int]:
        return sorted(self.by_id)

    def __len__(self) -> int:
        return sum(len(boxes) for boxes in self.by_id.values())

    def in_frame(self, frame: int) -> dict[int, Box]:
        return {i: boxes[frame] for i, boxes in self.by_id.items() if frame in boxes}

    def rows(self) -> Iterator[tuple[int, int, Box]]:
        """(frame, id, box) in frame order, then id order."""
        items = [(f, i, b) for i, boxes in self.by_id.items() for f, b in boxes.items()]
        yield from sorted(items, key=lambda item: (item[0], item[1]))

    def copy(self) -> Tracks:
        return Tracks({i: dict(boxes) for i, boxes in self.by_id.items()})


def _rows(path: Path) -> Iterator[list[str]]:
    for line in path.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            yield line.split(",")


def read_detections(path: Path) -> Detections:
    detections = Detections()
    for f in _rows(path):
        box = Box(float(f[2]), float(f[3]), float(f[4]), float(f[5]), float(f[6]))
        detections.by_frame.setdefault(int(f[0]), []).append(box)
    return detections


def read_tracks(path: Path) -> Tracks:
    """Tracks from a MOTChallenge file (a tracker's output or ground truth)."""
    tracks = Tracks()
    for f in _rows(path):
        visibility = float(f[8]) if len(f) > 8 else 1.0
        box = Box(float(f[2]), float(f[3]), float(f[4]), float(f[5]), float(f[6]), visibility)
        tracks.by_id.setdefault(int(f[1]), {})[int(f[0])] = box
    return tracks


def write_tracks(tracks: Tracks, path: Path) -> None:
    """The assistant's tracks: `frame, id, x, y, w, h, score, -1, -1, -1`."""
    lines = [
        f"{f},{i},{b.x:.2f},{b.y:.2f},{b.w:.2f},{b.h:.2f},{b.score:.4f},-1,-1,-1"
        for f, i, b in tracks.rows()
    ]
    path.write_text("\n".join(lines) + "\n")


def write_ground_truth(tracks: Tracks, path: Path) -> None:
    """MOTChallenge gt.txt: `frame, id, x, y, w, h, 1 (score it), 1 (pedestrian), visibility`."""
    lines = [
        f"{f},{i},{b.x:.2f},{b.y:.2f},{b.w:.2f},{b.h:.2f},1,1,{b.visibility:.3f}"
        for f, i, b in tracks.rows()
    ]
    path.write_text("\n".join(lines) + "\n")


@dataclass(frozen=True)
class SeqInfo:
    """MOTChallenge's seqinfo.ini: the clip's name, frame rate, length and size."""

    name: str
    fps: float
    length: int
    width: int
    height: int


def write_seqinfo(folder: Path, video: Path, size: tuple[int, int], length: int) -> None:
    capture = cv2.VideoCapture(str(video))
    fps = capture.get(cv2.CAP_PROP_FPS) or 10.0
    capture.release()
    (folder / "seqinfo.ini").write_text(
        f"[Sequence]\nname={video.stem}\nimDir=img1\nframeRate={fps:g}\nseqLength={length}\n"
        f"imWidth={size[0]}\nimHeight={size[1]}\nimExt=.jpg\n"
    )


def read_seqinfo(folder: Path) -> SeqInfo:
    parser = configparser.ConfigParser()
    parser.read(folder / "seqinfo.ini")
    s = parser["Sequence"]
    return SeqInfo(
        s["name"], float(s["frameRate"]), int(s["seqLength"]), int(s["imWidth"]), int(s["imHeight"])
    )
