"""Colour histograms of many rectangles of one image, and their Bhattacharyya coefficients against
a reference (seed 003's observation model), no rclpy.

A particle filter scores hundreds of rectangles per frame. Each pixel's bin is computed once per
frame (`bin_image`); `coefficients` then counts, per rectangle, the bins of its pixels in a compiled
loop (numba) and sums sqrt(p_b q_b) over the bins it touched:

    rho_B(p, q) = sum_b sqrt(p_b q_b),   p_b = c_b / n   (c_b: pixels in bin b, n: pixels)

so the cost is one memory read per pixel of each rectangle and nothing per empty bin (a 16^3-bin
RGB histogram has 4096 bins, a person's rectangle a few thousand pixels). Why compiled: in NumPy one
`bincount` per rectangle costs ~25 us, i.e. ~19 ms for 750 particles; a vectorised count over all
rectangles at once moves 750 x n indices through memory. `coefficients_reference` is the
straightforward NumPy version the kernel is tested against.

Colour spaces (`ColourSpace`): ``rgb``, the joint K x K x K histogram of the thesis (B, G, R bytes
of an OpenCV bgr8 image, no kernel weighting); ``hsv``, its Ext 3 (a K x K hue x saturation
histogram, V dropped).
"""

from __future__ import annotations

from enum import StrEnum

import cv2
import numba
import numpy as np

#: a rectangle as integer pixel bounds [x0, y0, x1, y1), clipped to the image
Bounds = np.ndarray  # (N, 4) int64


class ColourSpace(StrEnum):
    RGB = "rgb"
    HSV = "hsv"


def bin_count(space: ColourSpace, bins: int) -> int:
    """Bins of one histogram: K^3 for RGB, K^2 for H x S."""
    return bins**3 if ColourSpace(space) is ColourSpace.RGB else bins**2


def bin_image(image: np.ndarray, space: ColourSpace, bins: int) -> np.ndarray:
    """Each pixel's histogram bin (int32, H x W) for a bgr8 image and K = `bins` per channel."""
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise ValueError(
            f"expected a bgr8 image (H x W x 3 uint8), got {image.shape} {image.dtype}"
        )
    if not 2 <= bins <= 256:
        raise ValueError(f"bins per channel must be in [2, 256], got {bins}")
    if ColourSpace(space) is ColourSpace.RGB:
        index = (image.astype(np.int32) * bins) >> 8  # [0, 256) -> [0, K)
        rgb_bins: np.ndarray = (index[..., 2] * bins + index[..., 1]) * bins + index[..., 0]
        return rgb_bins
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)  # H in [0, 180), S in [0, 256)
    hue = (hsv[..., 0].astype(np.int32) * bins) // 180
    saturation = (hsv[..., 1].astype(np.int32) * bins) >> 8
    return hue * bins + saturation


def clip_bounds(boxes: np.ndarray, shape: tuple[int, ...]) -> Bounds:
    """Boxes (N, 4) as x, y, width, height (float px) -> integer [x0, y0, x1, y1) inside the image.

    A pixel belongs to a box when its centre does: x0 = round(x), x1 = round(x + width)."""
    height, width = shape[:2]
    x0 = np.clip(np.rint(boxes[:, 0]), 0, width)
    y0 = np.clip(np.rint(boxes[:, 1]), 0, height)
    x1 = np.clip(np.rint(boxes[:, 0] + boxes[:, 2]), 0, width)
    y1 = np.clip(np.rint(boxes[:, 1] + boxes[:, 3]), 0, height)
    return np.stack([x0, y0, np.maximum(x1, x0), np.maximum(y1, y0)], axis=1).astype(np.int64)


def histogram(bins_of_pixels: np.ndarray, bounds: np.ndarray, count: int) -> np.ndarray:
    """The normalised histogram of one rectangle [x0, y0, x1, y1) (zeros when it is empty)."""
    x0, y0, x1, y1 = (int(v) for v in bounds)
    counts = np.bincount(bins_of_pixels[y0:y1, x0:x1].ravel(), minlength=count).astype(float)
    total = counts.sum()
    return counts / total if total > 0 else counts


def coefficients(
    bins_of_pixels: np.ndarray, bounds: Bounds, sqrt_references: np.ndarray, which: np.ndarray
) -> np.ndarray:
    """rho_B of each rectangle's histogram against its reference: rectangle i against
    sqrt_references[which[i]] (the square roots of a normalised histogram). An empty
    rectangle has coefficient 0."""
    # particles resampled from one parent and moved by less than a pixel share their integer
    # rectangle: each distinct rectangle is counted once
    rows = np.column_stack([np.asarray(bounds, np.int64), np.asarray(which, np.int64)])
    distinct, inverse = np.unique(rows, axis=0, return_inverse=True)
    out = np.empty(len(distinct))
    _coefficients(
        np.ascontiguousarray(bins_of_pixels, dtype=np.int32),
        np.ascontiguousarray(distinct[:, :4]),
        np.ascontiguousarray(sqrt_references, dtype=np.float64),
        np.ascontiguousarray(distinct[:, 4]),
        out,
    )
    return out[inverse.ravel()]


def ring_coefficients(
    bins_of_pixels: np.ndarray,
    inner: Bounds,
    outer: Bounds,
    sqrt_reference: np.ndarray,
    stride: int = 1,
) -> np.ndarray:
    """rho_B against one reference of the ring between each pair of rectangles: the pixels of
    outer[i] that are not in inner[i] (inner inside outer), of those only every `stride`-th
    row and column of `bins_of_pixels` (a sample; 1: all). An empty ring has coefficient 0."""
    out = np.empty(len(inner))
    _ring_coefficients(
        np.ascontiguousarray(bins_of_pixels, dtype=np.int32),
        np.ascontiguousarray(inner, dtype=np.int64),
        np.ascontiguousarray(outer, dtype=np.int64),
        np.ascontiguousarray(sqrt_reference, dtype=np.float64),
        int(stride),
        out,
    )
    return out


def warm_up() -> None:
    """Compile (or load from numba's cache) the coefficient kernels now, not on a replay's first
    frames."""
    references = np.full((1, 4), 0.5)
    bins = np.zeros((4, 4), np.int32)
    coefficients(bins, np.array([[0, 0, 2, 2]]), references, np.zeros(1))
    ring_coefficients(bins, np.array([[1, 1, 2, 2]]), np.array([[0, 0, 3, 3]]), references[0])


def ring_coefficients_reference(
    bins_of_pixels: np.ndarray,
    inner: Bounds,
    outer: Bounds,
    sqrt_reference: np.ndarray,
    stride: int = 1,
) -> np.ndarray:
    """`ring_coefficients` in plain NumPy (for tests)."""
    count = len(sqrt_reference)
    sampled = np.zeros(bins_of_pixels.shape, dtype=bool)
    sampled[::stride, ::stride] = True
    out = []
    for (ix0, iy0, ix1, iy1), (ox0, oy0, ox1, oy1) in zip(inner, outer, strict=True):
        ring = sampled.copy()
        ring[:oy0], ring[oy1:], ring[:, :ox0], ring[:, ox1:] = False, False, False, False
        ring[iy0:iy1, ix0:ix1] = False
        counts = np.bincount(bins_of_pixels[ring], minlength=count).astype(float)
        total = counts.sum()
        out.append(float(np.sqrt(counts / total) @ sqrt_reference) if total else 0.0)
    return np.array(out)


def coefficients_reference(
    bins_of_pixels: np.ndarray, bounds: Bounds, sqrt_references: np.ndarray, which: np.ndarray
) -> np.ndarray:
    """`coefficients` in plain NumPy, one histogram per rectangle (for tests and comparison)."""
    count = sqrt_references.shape[1]
    return np.array(
        [
            float(np.sqrt(histogram(bins_of_pixels, b, count)) @ sqrt_references[r])
            for b, r in zip(bounds, which, strict=True)
        ]
    )


@numba.njit(cache=True, nogil=True)
def _take_coefficient(  # pragma: no cover
    counts: np.ndarray, pixels: int, held: np.ndarray, sqrt_reference: np.ndarray
) -> float:
    """rho_B of the histogram counted in `counts` (`pixels` > 0 of them) against a reference
    whose non-zero bins are `held`; empties `counts` for the next rectangle."""
    total = 0.0
    for b in held:
        total += np.sqrt(counts[b]) * sqrt_reference[b]
    counts[:] = 0
    rho: float = total / np.sqrt(pixels)
    return rho


@numba.njit(cache=True, nogil=True)
def _coefficients(  # pragma: no cover
    bins_of_pixels: np.ndarray,
    bounds: np.ndarray,
    sqrt_references: np.ndarray,
    which: np.ndarray,
    out: np.ndarray,
) -> None:
    count = sqrt_references.shape[1]
    counts = np.zeros(count, np.int32)
    # the bins each reference holds: only they add to the sum
    held = [np.flatnonzero(sqrt_references[r]) for r in range(sqrt_references.shape[0])]
    for i in range(bounds.shape[0]):
        x0, y0, x1, y1 = bounds[i, 0], bounds[i, 1], bounds[i, 2], bounds[i, 3]
        pixels = (x1 - x0) * (y1 - y0)
        if pixels <= 0:
            out[i] = 0.0
            continue
        for y in range(y0, y1):
            row = bins_of_pixels[y]
            for x in range(x0, x1):
                counts[row[x]] += 1
        out[i] = _take_coefficient(counts, pixels, held[which[i]], sqrt_references[which[i]])


@numba.njit(cache=True, nogil=True)
def _ring_coefficients(  # pragma: no cover
    bins_of_pixels: np.ndarray,
    inner: np.ndarray,
    outer: np.ndarray,
    sqrt_reference: np.ndarray,
    stride: int,
    out: np.ndarray,
) -> None:
    counts = np.zeros(len(sqrt_reference), np.int32)
    held = np.flatnonzero(sqrt_reference)
    for i in range(inner.shape[0]):
        ix0, iy0, ix1, iy1 = inner[i, 0], inner[i, 1], inner[i, 2], inner[i, 3]
        ox0, oy0, ox1, oy1 = outer[i, 0], outer[i, 1], outer[i, 2], outer[i, 3]
        pixels = 0
        for y in range(oy0 + (-oy0) % stride, oy1, stride):
            row = bins_of_pixels[y]
            beside = iy0 <= y < iy1 and ix1 > ix0  # a row through the box: its left and right
            for x in range(ox0 + (-ox0) % stride, ox1, stride):
                if beside and ix0 <= x < ix1:
                    continue
                counts[row[x]] += 1
                pixels += 1
        out[i] = _take_coefficient(counts, pixels, held, sqrt_reference) if pixels > 0 else 0.0
