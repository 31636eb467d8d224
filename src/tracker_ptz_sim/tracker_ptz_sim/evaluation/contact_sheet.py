"""A contact sheet of a run: what the camera followed, one tile every few seconds (no rclpy).

Each tile is the recorded scene cropped around the locked target, with the target track's box
(yellow), the target point and the camera window's edges (green) drawn, and the time and track id
written under it; a frame without a lock shows the camera window instead, marked "no lock". Meant
to be looked at: is the followed thing what a person would call the target?
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from tracker_msgs_py.codec import NS_PER_S, decode_image, msg_to_rect, stamp_to_ns
from tracker_ptz_sim.evaluation.recording import read_bag
from tracker_ptz_sim.evaluation.run_report import SCENE, FrameRecord, frame_numbers, stream_fps

TILE = 220  # px, side of a tile
CROP = 300  # scene px around the target shown in a tile
COLUMNS = 6
LABEL_HEIGHT = 22


def sampled_stamps(frames: dict[int, FrameRecord], every_s: float) -> list[int]:
    """One image stamp every `every_s` seconds of the recording, from its first frame."""
    numbers = frame_numbers(frames)
    step = max(1, round(every_s * stream_fps(frames)))
    return [stamp for stamp, number in numbers.items() if (number - 1) % step == 0]


def write_contact_sheet(
    bag: Path, frames: dict[int, FrameRecord], path: Path, every_s: float = 2.0
) -> int:
    """Write the sheet of frames sampled every `every_s` s to `path` (PNG); how many tiles."""
    wanted = set(sampled_stamps(frames, every_s))
    tiles: dict[int, np.ndarray] = {}
    for _, _, msg in read_bag(bag, {SCENE}):
        stamp = stamp_to_ns(msg.header.stamp)
        if stamp in wanted and stamp not in tiles:
            tiles[stamp] = tile(decode_image(msg), frames[stamp], stamp)
    if not tiles:
        return 0
    ordered = [tiles[s] for s in sorted(tiles)]
    blank = np.full_like(ordered[0], 255)
    ordered += [blank] * (-len(ordered) % COLUMNS)
    rows = [np.hstack(ordered[i : i + COLUMNS]) for i in range(0, len(ordered), COLUMNS)]
    if not cv2.imwrite(str(path), np.vstack(rows)):
        raise OSError(f"OpenCV cannot write {path}")
    return len(tiles)


def tile(scene: np.ndarray, record: FrameRecord, stamp: int) -> np.ndarray:
    """One tile: the scene around the target (or the window when nothing is locked), labelled."""
    canvas = scene.copy()
    target = record.target if record.target is not None and record.target.locked else None
    if record.state is not None:
        window = msg_to_rect(record.state.window)
        corners = (round(window.x), round(window.y))
        far = (round(window.x + window.width) - 1, round(window.y + window.height) - 1)
        cv2.rectangle(canvas, corners, far, (0, 200, 0), 2)
        centre = window.center
    else:
        centre = (scene.shape[1] / 2, scene.shape[0] / 2)
    if target is not None:
        box = msg_to_rect(target.track.bbox)
        top_left = (round(box.x), round(box.y))
        bottom_right = (round(box.x + box.width), round(box.y + box.height))
        cv2.rectangle(canvas, top_left, bottom_right, (0, 255, 255), 2)
        cv2.circle(canvas, (round(target.track.x), round(target.track.y)), 4, (0, 255, 255), -1)
        centre = (target.track.x, target.track.y)
    crop = _crop(canvas, centre)
    label = f"{stamp / NS_PER_S:5.1f} s  " + (
        f"track #{target.track.id}" if target is not None else "no lock"
    )
    image = cv2.resize(crop, (TILE, TILE), interpolation=cv2.INTER_AREA)
    strip = np.full((LABEL_HEIGHT, TILE, 3), 255, np.uint8)
    cv2.putText(strip, label, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1)
    framed = np.vstack([image, strip])
    return cv2.copyMakeBorder(framed, 2, 2, 2, 2, cv2.BORDER_CONSTANT, value=(255, 255, 255))


def _crop(image: np.ndarray, centre: tuple[float, float]) -> np.ndarray:
    """A CROP x CROP square of `image` around `centre`, moved inside the image (padded when the
    image is smaller)."""
    height, width = image.shape[:2]
    side = min(CROP, width, height)
    x0 = int(min(max(round(centre[0] - side / 2), 0), width - side))
    y0 = int(min(max(round(centre[1] - side / 2), 0), height - side))
    return image[y0 : y0 + side, x0 : x0 + side]
