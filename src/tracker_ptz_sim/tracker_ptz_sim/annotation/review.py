"""Contact sheets for reviewing an annotation by eye (no rclpy).

Every `every`-th frame with each person's box and id, in a colour of its own (the same id, the
same colour on every page), four frames to a page at full size so that a box a few px off shows.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from tracker_ptz_sim.annotation.assistant import read_frames
from tracker_ptz_sim.annotation.linking import Tracks

COLUMNS, ROWS = 2, 2


def colour(ident: int) -> tuple[int, int, int]:
    """A bright BGR colour of its own for each id (golden-ratio hues)."""
    hue = int((ident * 0.618034 % 1.0) * 180)
    hsv = np.array([[[hue, 220, 255]]], np.uint8)
    b, g, r = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
    return int(b), int(g), int(r)


def draw(frame: np.ndarray, number: int, tracks: Tracks) -> np.ndarray:
    """The frame with its boxes, ids and frame number."""
    image = frame.copy()
    for ident, box in sorted(tracks.in_frame(number).items()):
        c = colour(ident)
        p0 = (round(box.x), round(box.y))
        p1 = (round(box.x + box.w), round(box.y + box.h))
        thickness = 1 if box.score == 0.0 else 2  # interpolated boxes thin
        cv2.rectangle(image, p0, p1, c, thickness)
        label = str(ident)
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
        top = max(p0[1] - th - 4, 0)
        cv2.rectangle(image, (p0[0], top), (p0[0] + tw + 4, top + th + 4), c, -1)
        cv2.putText(
            image, label, (p0[0] + 2, top + th + 1), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1
        )
    cv2.putText(image, f"frame {number}", (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 0), 4)
    cv2.putText(
        image, f"frame {number}", (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2
    )
    return image


def contact_sheets(video: Path, tracks: Tracks, folder: Path, every: int = 10) -> list[Path]:
    """Write `folder/sheet_NNN.png` pages of every `every`-th frame (1, 1 + every, ...)."""
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("sheet_*.png"):
        old.unlink()
    tiles = [
        draw(frame, index + 1, tracks)
        for index, frame in enumerate(read_frames(video))
        if index % every == 0
    ]
    pages = []
    per_page = COLUMNS * ROWS
    for start in range(0, len(tiles), per_page):
        chunk = tiles[start : start + per_page]
        blank = np.zeros_like(chunk[0])
        chunk += [blank] * (per_page - len(chunk))
        rows = [np.hstack(chunk[r * COLUMNS : (r + 1) * COLUMNS]) for r in range(ROWS)]
        path = folder / f"sheet_{start // per_page + 1:03d}.png"
        cv2.imwrite(str(path), np.vstack(rows))
        pages.append(path)
    return pages
