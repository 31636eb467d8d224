"""A background mosaic of the surveillance area, kept in scene coordinates (no rclpy).

The camera sees a moving window of a static scene; every view it has seen is blended into one
grey image of the scene (the mosaic), so a later view can be compared with what the scene looks
like without its movers (`sample`), wherever the camera points. Beside the mean it keeps, per
scene pixel, how often it was observed (the first observations are averaged: rate 1/n) and a
flicker rate: the running share of frames in which that pixel was foreground *and* changing
(fluttering tape, foliage, flicker). That is seed 000's calibration mask of always-moving areas
(§1, "removed from the final system"), learned instead of drawn. Given colour views, it also
keeps the background's chromaticity (r, g), blended like the grey, to tell cast shadows apart.

Coordinates: scene pixels, origin at the top-left corner of the top-left pixel; the mosaic grows
to cover every view it is given, so no scene size is needed up front.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numba
import numpy as np

from tracker_detect.registration import View

GROW_MARGIN = 64  # scene px added around a view that reaches beyond the mosaic


@dataclass(frozen=True)
class MosaicSample:
    """The mosaic seen through one view, in that view's image pixels."""

    mean: np.ndarray  # (H, W) float32 grey background
    observations: np.ndarray  # (H, W) float32 times each pixel was observed (0: never)
    flicker: np.ndarray  # (H, W) float32 share of frames foreground and changing, in [0, 1]
    chroma: np.ndarray | None = None  # (H, W, 2) float32 background r, g chromaticity, if kept


class SceneMosaic:
    """Running grey background, observation counts and flicker rates over the scene."""

    def __init__(self, warmup_observations: int = 20, flicker_memory: float = 100.0) -> None:
        if warmup_observations < 1 or not flicker_memory >= 1.0:
            raise ValueError("warmup_observations and flicker_memory must be >= 1")
        self.warmup_observations = warmup_observations
        self.flicker_memory = flicker_memory
        self.origin = (0, 0)  # scene px of the mosaic's pixel (0, 0) corner
        self.mean = np.zeros((0, 0), np.float32)
        self.observations = np.zeros((0, 0), np.float32)
        self.flicker = np.zeros((0, 0), np.float32)
        self.chroma: np.ndarray | None = None  # (H, W, 2) once a colour view was blended in

    @property
    def empty(self) -> bool:
        return self.mean.size == 0

    def clear(self) -> None:
        self.__init__(self.warmup_observations, self.flicker_memory)  # type: ignore[misc]

    def sample(self, view: View) -> MosaicSample:
        """The mosaic resampled to `view`'s image (zeros where it was never observed)."""
        self._cover(view)
        matrix = self._view_to_mosaic(view)
        size = (view.width, view.height)

        def warp(layer: np.ndarray) -> np.ndarray:
            return _warp(layer, matrix, size, cv2.BORDER_CONSTANT)

        chroma = None if self.chroma is None else warp(self.chroma)
        return MosaicSample(warp(self.mean), warp(self.observations), warp(self.flicker), chroma)

    def update(
        self,
        view: View,
        image: np.ndarray,
        rate: np.ndarray,
        changing: np.ndarray,
        chroma: np.ndarray | None = None,
    ) -> None:
        """Blend `image` (and its (H, W, 2) `chroma`, when given) in where it was seen:
        mean += r (image - mean), where r is `rate`
        (image px, per frame) or, where it is > 0, at least 1/n for a pixel's first
        `warmup_observations` observations (the first observation is always taken); the
        flicker rate is the share of observations with `changing` (0/1, image px) set, over the last
        ~flicker_memory observations."""
        self._cover(view)
        x0, y0, x1, y1 = self._footprint(view)
        if x1 <= x0 or y1 <= y0:
            return
        # The image's pixels at the footprint's mosaic pixels (forward map of `sample`).
        matrix = np.linalg.inv(np.vstack([self._view_to_mosaic(view), [0.0, 0.0, 1.0]]))[:2]
        matrix[:, 2] += matrix[:, 0] * x0 + matrix[:, 1] * y0
        size = (x1 - x0, y1 - y0)
        layers = cv2.merge(
            [image.astype(np.float32), rate.astype(np.float32), changing.astype(np.float32)]
        )
        seen = _warp(layers, matrix, size, cv2.BORDER_REPLICATE)
        if _aligned(matrix, size, image.shape) is None:
            inside = (
                cv2.warpAffine(
                    np.ones(image.shape, np.float32),
                    matrix,
                    size,
                    flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                )
                > 0.5
            )
        else:
            inside = np.ones((size[1], size[0]), np.bool_)
        background_chroma = seen_chroma = None
        if chroma is not None:
            if self.chroma is None:
                self.chroma = np.zeros((*self.mean.shape, 2), np.float32)
            seen_chroma = _warp(chroma.astype(np.float32), matrix, size, cv2.BORDER_REPLICATE)
            background_chroma = self.chroma[y0:y1, x0:x1]
        _blend(
            self.mean[y0:y1, x0:x1],
            self.observations[y0:y1, x0:x1],
            self.flicker[y0:y1, x0:x1],
            background_chroma,
            seen,
            inside,
            seen_chroma,
            self.warmup_observations,
            np.float32(self.flicker_memory),
        )

    def _view_to_mosaic(self, view: View) -> np.ndarray:
        """2x3 affine map from view image pixel indices to mosaic pixel indices (pixel centres)."""
        sx, sy = view.scale_x, view.scale_y
        ox, oy = self.origin
        return np.array(
            [
                [sx, 0.0, view.rect.x - ox + 0.5 * sx - 0.5],
                [0.0, sy, view.rect.y - oy + 0.5 * sy - 0.5],
            ]
        )

    def _footprint(self, view: View) -> tuple[int, int, int, int]:
        """Mosaic pixel bounds [x0, x1) x [y0, y1) of the view."""
        ox, oy = self.origin
        h, w = self.mean.shape
        x0 = max(int(np.floor(view.rect.x - ox)), 0)
        y0 = max(int(np.floor(view.rect.y - oy)), 0)
        x1 = min(int(np.ceil(view.rect.x + view.rect.width - ox)), w)
        y1 = min(int(np.ceil(view.rect.y + view.rect.height - oy)), h)
        return x0, y0, x1, y1

    def pixels_covering(self, view: View) -> int:
        """Mosaic pixels once it contains `view` (its size now when it already does)."""
        bounds = self._covering_bounds(view)
        if bounds is None:
            return int(self.mean.size)
        left, top, right, bottom = bounds
        return (right - left) * (bottom - top)

    def _covering_bounds(self, view: View) -> tuple[int, int, int, int] | None:
        """Scene px (left, top, right, bottom) of the mosaic grown (by at least GROW_MARGIN) to
        contain `view`; None when it already does."""
        r = view.rect
        ox, oy = self.origin
        h, w = self.mean.shape
        if not self.empty and (
            r.x >= ox and r.y >= oy and r.x + r.width <= ox + w and r.y + r.height <= oy + h
        ):
            return None
        if self.empty:
            left, top = int(np.floor(r.x)), int(np.floor(r.y))
            right, bottom = int(np.ceil(r.x + r.width)), int(np.ceil(r.y + r.height))
            return left, top, right, bottom
        left = min(ox, int(np.floor(r.x)) - GROW_MARGIN) if r.x < ox else ox
        top = min(oy, int(np.floor(r.y)) - GROW_MARGIN) if r.y < oy else oy
        right = max(ox + w, int(np.ceil(r.x + r.width)) + GROW_MARGIN)
        bottom = max(oy + h, int(np.ceil(r.y + r.height)) + GROW_MARGIN)
        if r.x + r.width <= ox + w:
            right = ox + w
        if r.y + r.height <= oy + h:
            bottom = oy + h
        return left, top, right, bottom

    def _cover(self, view: View) -> None:
        """Grow the mosaic until it contains `view`."""
        bounds = self._covering_bounds(view)
        if bounds is None:
            return
        left, top, right, bottom = bounds
        ox, oy = self.origin
        h, w = self.mean.shape
        shape = (bottom - top, right - left)

        def grown(old: np.ndarray) -> np.ndarray:
            new = np.zeros(shape + old.shape[2:], np.float32)
            if old.size:
                new[oy - top : oy - top + h, ox - left : ox - left + w] = old
            return new

        self.mean, self.observations, self.flicker = (
            grown(old) for old in (self.mean, self.observations, self.flicker)
        )
        if self.chroma is not None:
            self.chroma = grown(self.chroma)
        self.origin = (left, top)


def _aligned(
    matrix: np.ndarray, size: tuple[int, int], source: tuple[int, ...]
) -> tuple[int, int] | None:
    """(column, row) of the source pixel at the output's (0, 0) when the inverse map `matrix`
    is a whole-pixel shift and the output (width, height) `size` lies inside the `source`
    shape; else None."""
    if not np.array_equal(matrix[:, :2], np.eye(2)):
        return None
    shift = matrix[:, 2]
    if not np.array_equal(shift, np.round(shift)):
        return None
    column, row = int(shift[0]), int(shift[1])
    width, height = size
    inside = column >= 0 and row >= 0 and column + width <= source[1] and row + height <= source[0]
    return (column, row) if inside else None


def _warp(layer: np.ndarray, matrix: np.ndarray, size: tuple[int, int], border: int) -> np.ndarray:
    """`layer` resampled bilinearly through the inverse map `matrix` to (width, height)
    `size`, outside it `border` (zeros for BORDER_CONSTANT); a whole-pixel shift inside the
    layer is a copy of its pixels, which is what the interpolation gives there."""
    corner = _aligned(matrix, size, layer.shape)
    if corner is not None:
        column, row = corner
        return layer[row : row + size[1], column : column + size[0]].copy()
    warped: np.ndarray = cv2.warpAffine(
        layer,
        matrix,
        size,
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=border,
        borderValue=0.0,
    )
    return warped.reshape(size[1], size[0], *layer.shape[2:])


_PLANE, _LAYERS = numba.float32[:, :], numba.float32[:, :, :]


# One explicit signature (any layout, chroma optional): compiled, or loaded from numba's cache, at
# import, before a node subscribes; a signature per call's layouts would compile on a graph's
# first frame (the whole-mosaic slice of a static view is contiguous) and stall its lockstep.
@numba.njit(
    numba.void(
        _PLANE, _PLANE, _PLANE, numba.optional(_LAYERS), _LAYERS, numba.boolean[:, :],
        numba.optional(_LAYERS), numba.int64, numba.float32,
    ),
    cache=True,
    nogil=True,
)  # fmt: skip
def _blend(  # pragma: no cover
    mean: np.ndarray,
    count: np.ndarray,
    flicker: np.ndarray,
    chroma: np.ndarray | None,
    seen: np.ndarray,
    inside: np.ndarray,
    seen_chroma: np.ndarray | None,
    warmup_observations: int,
    flicker_memory: np.float32,
) -> None:
    """`update`'s arithmetic, pixel by pixel in float32 (seen: grey, rate, changing):
    count += inside
    warm-up = max(1 / max(count, 1), rate) where rate > 0 or count <= 1, else 0
    blend = (warm-up while count <= warmup_observations, else rate) * inside
    mean += blend (grey - mean);  chroma += blend (seen chroma - chroma)
    flicker += inside (changing - flicker) / min(max(count, 1), flicker_memory)"""
    one, zero = np.float32(1.0), np.float32(0.0)
    for y in range(mean.shape[0]):
        for x in range(mean.shape[1]):
            observed = one if inside[y, x] else zero
            n = count[y, x] + observed
            count[y, x] = n
            rate = seen[y, x, 1]
            at_least_one = max(n, one)
            warmup = max(one / at_least_one, rate) if rate > zero or n <= one else zero
            blend = (warmup if n <= warmup_observations else rate) * observed
            mean[y, x] += blend * (seen[y, x, 0] - mean[y, x])
            if chroma is not None and seen_chroma is not None:
                for c in range(2):
                    chroma[y, x, c] += blend * (seen_chroma[y, x, c] - chroma[y, x, c])
            memory = min(at_least_one, flicker_memory)
            flicker[y, x] += observed * (seen[y, x, 2] - flicker[y, x]) / memory
