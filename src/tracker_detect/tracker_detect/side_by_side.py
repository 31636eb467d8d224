"""Cut a foreground mask between people standing side by side (no rclpy).

Two people walking together, or one passing just in front of another, are one connected blob and
one box over both. Their heads stay apart: along the blob's top outline (per column, the row of
its highest pixel) each head is a peak, and between two heads the outline dips to the shoulders.
A blob at least `WIDE_ASPECT` as wide as it is tall is cut, one column of pixels wide, at the
deepest dip of its (lightly smoothed) outline that lies at least `depth` x the blob's height
below the higher points on both sides of it, each side being at least `MIN_SIDE` x its height
wide (a person, not an arm); each side is then cut the same way (three abreast). A person with a
strip of barrier tape or a post joined at their side is cut from it the same way when the strip
rises beside them (a flutter of tape is as high as a head where it hangs from a post); a lone
person's outline falls from the head to the shoulders and feet and has no such dip. Flat blobs
(wider than `FLAT_ASPECT` x their height: a strip of tape lying, the smear a camera shake leaves
along an edge) and blobs under `MIN_HEIGHT` px are left whole: cut, they would give upright
pieces of clutter.

The cut makes the pieces separate connected components, so every later step (boxes, dropping
flat blobs, joining a person's fragments, growing legs) sees each on its own.
"""

from __future__ import annotations

import numpy as np

from tracker_detect.motion import components

WIDE_ASPECT = 0.6  # width / height from which a blob may hold people side by side
FLAT_ASPECT = 3.0  # ... up to this: flatter blobs are tape or smears
MIN_HEIGHT = 20  # px: smaller blobs are not people side by side
MIN_SIDE = 0.2  # x height: each side of a cut is at least a person's narrowest width
SMOOTHING = 0.04  # x height: half-width of the running mean over the outline


def top_outline(component: np.ndarray) -> np.ndarray:
    """Per column of a boolean (H, W) component, the row of its highest pixel (H where none)."""
    filled = component.any(axis=0)
    result: np.ndarray = np.where(filled, component.argmax(axis=0), component.shape[0])
    return result


def valley_columns(outline: np.ndarray, height: float, depth: float) -> list[int]:
    """Indices of `outline` (top rows per column of a blob `height` px tall) to cut at: the
    deepest qualifying dip (module doc), then the same on each side, left to right."""
    count = len(outline)
    side = max(1, int(MIN_SIDE * height))
    if count < 2 * side + 1:
        return []
    reach = max(1, round(SMOOTHING * height))
    padded = np.pad(outline.astype(float), reach, mode="edge")
    smooth = np.convolve(padded, np.full(2 * reach + 1, 1.0 / (2 * reach + 1)), mode="valid")
    left_peak = np.minimum.accumulate(smooth)  # highest point (least row) up to each column
    right_peak = np.minimum.accumulate(smooth[::-1])[::-1]
    columns = np.arange(side, count - side)
    lower_peak = np.maximum(left_peak[columns - 1], right_peak[columns + 1])
    dips = smooth[columns] - lower_peak
    qualifies = dips >= depth * height
    if not qualifies.any():
        return []
    cut = int(columns[np.argmax(np.where(qualifies, dips, -np.inf))])
    left = valley_columns(outline[:cut], height, depth)
    right = valley_columns(outline[cut + 1 :], height, depth)
    return left + [cut] + [cut + 1 + c for c in right]


def cut_side_by_side(mask: np.ndarray, depth: float, connectivity: int = 8) -> np.ndarray:
    """`mask` (uint8, nonzero = foreground) with every blob of people side by side cut apart
    (module doc); the input itself when nothing is cut."""
    parts = components(mask, connectivity)
    result = mask
    for label in range(1, parts.count):
        x, y, width, height = parts.box(label)
        if height < MIN_HEIGHT or not WIDE_ASPECT * height <= width <= FLAT_ASPECT * height:
            continue
        component = parts.labels[y : y + height, x : x + width] == label
        for column in valley_columns(top_outline(component), height, depth):
            if result is mask:
                result = mask.copy()
            rows = np.flatnonzero(component[:, column])
            result[y + rows, x + column] = 0
    return result
