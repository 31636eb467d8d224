"""Contact sheets for reviewing an annotation by eye (no rclpy).

Every `every`-th frame with each person's box and id, in a colour of its own (the same id, the
same colour on every page), four frames to a page at full size so that a box a few px off shows;
and the busy part of the frame (where people cross, pass behind the sign) magnified. Boxes the
interpolation filled in are drawn thin.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from tracker_ptz_sim.simulation.frame_sources import video_frames
from tracker_ptz_sim.simulation.ground_truth import Box, Tracks

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


def zoomed(
    frame: np.ndarray, number: int, tracks: Tracks, region: tuple[int, int, int, int], scale: int
) -> np.ndarray:
    """`region` (x, y, w, h) of the frame magnified `scale` times, boxes drawn at that size."""
    x, y, w, h = region
    big = cv2.resize(
        frame[y : y + h, x : x + w], None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC
    )
    moved = Tracks(
        {
            i: {
                f: Box((b.x - x) * scale, (b.y - y) * scale, b.w * scale, b.h * scale, b.score)
                for f, b in boxes.items()
                if f == number
            }
            for i, boxes in tracks.by_id.items()
        }
    )
    return draw(big, number, moved)


def grid(image: np.ndarray, region: tuple[int, int, int, int], scale: int, step: int = 20) -> None:
    """Lines every `step` frame px across the magnified image, every other one labelled with its
    frame coordinate: boxes for the corrections file are read off them."""
    x, y, w, h = region
    for k, v in enumerate(range((x // step + 1) * step, x + w, step)):
        u = (v - x) * scale
        cv2.line(
            image, (u, 0), (u, image.shape[0]), (255, 255, 0) if k % 2 == 0 else (160, 160, 0), 1
        )
        if k % 2 == 0:
            cv2.putText(
                image, str(v), (u + 2, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.35, (255, 255, 255), 1
            )
    for k, v in enumerate(range((y // step + 1) * step, y + h, step)):
        u = (v - y) * scale
        cv2.line(
            image, (0, u), (image.shape[1], u), (255, 255, 0) if k % 2 == 0 else (160, 160, 0), 1
        )
        if k % 2 == 0:
            cv2.putText(
                image, str(v), (20, u + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.35, (255, 255, 255), 1
            )


def strip(
    video: Path,
    tracks: Tracks,
    frames: range,
    region: tuple[int, int, int, int],
    scale: int,
    path: Path,
    width: int = 1500,
) -> int:
    """Frames `frames` of `region` magnified with boxes, ids and a coordinate grid, in rows up to
    `width` px wide, into one image at `path`; how many frames it shows."""
    tiles = []
    for index, frame in enumerate(video_frames(video)):
        if index + 1 in frames:
            tile = zoomed(frame, index + 1, tracks, region, scale)
            grid(tile, region, scale)
            tiles.append(tile)
    if not tiles:
        return 0
    columns = max(1, width // tiles[0].shape[1])
    blank = np.zeros_like(tiles[0])
    rows = [
        np.hstack(tiles[r : r + columns] + [blank] * (columns - len(tiles[r : r + columns])))
        for r in range(0, len(tiles), columns)
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.vstack(rows))
    return len(tiles)


def contact_sheets(
    video: Path,
    tracks: Tracks,
    folder: Path,
    every: int = 10,
    region: tuple[int, int, int, int] | None = None,
    scale: int = 2,
) -> list[Path]:
    """Write `folder/sheet_NNN.png` pages of every `every`-th frame (1, 1 + every, ...), four
    whole frames a page; with `region`, `folder/zoom_NNN.png` pages of that part magnified
    `scale` times, six a page."""
    folder.mkdir(parents=True, exist_ok=True)
    prefix = "sheet" if region is None else "zoom"
    for old in folder.glob(f"{prefix}_*.png"):
        old.unlink()
    tiles = [
        draw(frame, index + 1, tracks)
        if region is None
        else zoomed(frame, index + 1, tracks, region, scale)
        for index, frame in enumerate(video_frames(video))
        if index % every == 0
    ]
    columns, rows = (COLUMNS, ROWS) if region is None else (2, 3)
    pages = []
    per_page = columns * rows
    for start in range(0, len(tiles), per_page):
        chunk = tiles[start : start + per_page]
        blank = np.zeros_like(chunk[0])
        chunk += [blank] * (per_page - len(chunk))
        lines = [np.hstack(chunk[r * columns : (r + 1) * columns]) for r in range(rows)]
        path = folder / f"{prefix}_{start // per_page + 1:03d}.png"
        cv2.imwrite(str(path), np.vstack(lines))
        pages.append(path)
    return pages
