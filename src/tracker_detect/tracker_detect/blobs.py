"""Blobs: a mask's connected components as `detector.Blob`s, the seed's presence test, and the
blob parameters several detectors share, declared once (no rclpy).

A detector's config writes ``connectivity: int = blobs.connectivity(8)`` and gets the one
description, range and check.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from scipy import ndimage

from tracker_detect.detector import Blob
from tracker_detect.registration import View
from tracker_msgs_py.params import param


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """Set the background regions not 4-connected to the border (MATLAB imfill(bw, 'holes'))."""
    h, w = mask.shape
    padded = cv2.copyMakeBorder(mask, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    cv2.floodFill(padded, None, (0, 0), 1, flags=4)
    # padded is now 1 on the mask and on the background reached from outside; 0 only in holes.
    return cv2.bitwise_or(mask, 1 - padded[1 : h + 1, 1 : w + 1])


@dataclass(frozen=True)
class Components:
    """The connected components of a mask: `labels` (H, W) int32, 0 the background and 1 ..
    count - 1 the components, and each component's bounding (rows, columns) slices."""

    count: int
    labels: np.ndarray
    slices: list[tuple[slice, slice]]

    def box(self, label: int) -> tuple[int, int, int, int]:
        """Component `label`'s tight box: x, y, width, height (px)."""
        rows, columns = self.slices[label - 1]
        return columns.start, rows.start, columns.stop - columns.start, rows.stop - rows.start


def components(mask: np.ndarray, connectivity: int = 8) -> Components:
    """`mask`'s (uint8, nonzero = foreground) connected components, labelled as
    cv2.connectedComponentsWithStats labels them. Its statistics pass cost ten times the
    labelling itself here (OpenCV 5.0: 0.2 of 0.22 ms on a 264 x 264 view); the boxes come from
    one scan of the labels instead, and a component's own figures from its box alone."""
    count, labels = cv2.connectedComponents(mask, connectivity=connectivity, ltype=cv2.CV_32S)
    found = ndimage.find_objects(labels, count - 1) if count > 1 else []
    # the labels are 1 .. count - 1 without a gap: no component lacks its slices
    return Components(count, labels, [part for part in found if part is not None])


def find_blobs(
    mask: np.ndarray, similarity: np.ndarray, view: View, connectivity: int = 4
) -> list[Blob]:
    """Connected components of `mask`, largest first (blobs[0] is the seed's target)."""
    parts = components(mask, connectivity)
    blobs = []
    for label, (rows, columns) in enumerate(parts.slices, start=1):
        local = parts.labels[rows, columns]
        ys, xs = np.nonzero(local == label)
        n = len(xs)
        # summed in the pixels' row-major order, as one bincount over the whole image would
        ssim_sum = np.bincount(
            local.ravel(), weights=similarity[rows, columns].ravel(), minlength=label + 1
        )[label]
        x, y, w, h = parts.box(label)
        # the mean of the image coordinates, one division of exact sums as OpenCV's centroids
        mean_x, mean_y = (int(xs.sum()) + n * x) / n, (int(ys.sum()) + n * y) / n
        cx, cy = view.to_scene(mean_x + 0.5, mean_y + 0.5)
        blobs.append(
            Blob(
                cx,
                cy,
                view.rect_to_scene(x, y, w, h),
                n * view.scale_x * view.scale_y,
                n,
                float(ssim_sum / n),
            )
        )
    blobs.sort(key=lambda b: (-b.pixel_count, b.centroid_y, b.centroid_x))
    return blobs


def largest_blob(blobs: Sequence[Blob]) -> Blob | None:
    """The seed's target rule: the blob with the largest area."""
    return max(blobs, key=lambda b: b.pixel_count, default=None)


def presence_test(blob_pixels: int, compared_pixels: int, min_fraction: float = 0.0008) -> bool:
    """The seed's presence test: total blob area >= min_fraction (0.08 %) of the compared area."""
    return compared_pixels > 0 and blob_pixels > 0 and blob_pixels >= min_fraction * compared_pixels


# --- the shared blob parameters ---------------------------------------------------------------


def connectivity(default: int) -> Any:
    return param(
        default,
        "blob pixel connectivity (4 or 8)",
        min=4,
        max=8,
        validator=lambda v: None if v in (4, 8) else "connectivity must be 4 or 8",
    )


def min_blob_area(default: float) -> Any:
    return param(default, "drop blobs smaller than this", min=0.0, max=1e9, unit="scene px^2")


def presence_fraction(default: float) -> Any:
    return param(
        default,
        "presence test: total blob area >= this fraction of the compared area",
        min=0.0,
        max=1.0,
    )


def auto_downsample(default: bool) -> Any:
    return param(default, "Wang's automatic downsampling, f = round(min(H, W) / 256)")


def odd_side(default: int, description: str, name: str) -> Any:
    """An odd side of a square or elliptic element, 1 to 51 px."""
    return param(
        default,
        description,
        min=1,
        max=51,
        unit="px",
        validator=lambda v: None if v % 2 else f"{name} must be odd",
    )
