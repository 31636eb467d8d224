"""Ego-motion compensation: where the previous camera image lies in the current one (no rclpy).

Seed 000 §4 aligns the two camera windows before comparing them, either from the known window
positions ("option 1") or by an exhaustive search maximising the simplified SSIM ("option 2").
This module provides both, a fast phase-correlation estimator, and the alignment itself.

Conventions. A camera image shows `View.rect` of the scene (scene px, see tracker_msgs Rect);
image coordinates are continuous with the origin at the top-left corner of the top-left pixel.
`PixelMap` maps current-image coordinates to previous-image coordinates, u_prev = s * u + t.
A *shift* (dx, dy) is the camera's displacement from the previous image to the current one, in
image px: the current pixel p shows what the previous pixel p + (dx, dy) showed, so the scene
content moves by (-dx, -dy) in the image (the seed's correccion_desplazamiento.m returns that
content motion, i.e. the opposite sign). It equals the difference of the window corners when
the scale does not change: seed example, centres [80, 60] -> [50, 40] give (-30, -20).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any

import cv2
import numpy as np
import scipy.fft

from tracker_detect.ssim import BoxStatistics, SsimParams, box_statistics
from tracker_msgs_py.codec import MAX_MESSAGE_VALUE, usable_value
from tracker_msgs_py.geometry import Rect, SceneGeometry, camera_pixel_to_angles

#: Fractional shifts closer than this to an integer are aligned by cropping, without resampling.
INTEGER_TOLERANCE = 1e-3


@dataclass(frozen=True)
class View:
    """Where a width x height camera image lies in the scene: it shows `rect` (scene px)."""

    rect: Rect
    width: int  # image px
    height: int

    def __post_init__(self) -> None:
        values = (self.rect.x, self.rect.y, self.rect.width, self.rect.height)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"view rectangle must be finite, got {values}")
        if self.rect.width <= 0 or self.rect.height <= 0 or self.width <= 0 or self.height <= 0:
            raise ValueError(
                f"view needs positive sizes, got {self.rect} for {self.width}x{self.height} px"
            )

    @classmethod
    def identity(cls, width: int, height: int) -> View:
        """A static camera whose image is the scene itself."""
        return cls(Rect(0.0, 0.0, float(width), float(height)), width, height)

    @property
    def scale_x(self) -> float:
        """Scene px per image px along x."""
        return self.rect.width / self.width

    @property
    def scale_y(self) -> float:
        return self.rect.height / self.height

    def to_scene(self, u: float, v: float) -> tuple[float, float]:
        """Scene point of image point (u, v) (continuous image coordinates)."""
        return (self.rect.x + u * self.scale_x, self.rect.y + v * self.scale_y)

    def rect_to_scene(self, x: float, y: float, width: float, height: float) -> Rect:
        return Rect(
            self.rect.x + x * self.scale_x,
            self.rect.y + y * self.scale_y,
            width * self.scale_x,
            height * self.scale_y,
        )

    def rect_to_image(self, rect: Rect) -> Rect:
        """A scene rectangle in image px (the inverse of `rect_to_scene`)."""
        return Rect(
            (rect.x - self.rect.x) / self.scale_x,
            (rect.y - self.rect.y) / self.scale_y,
            rect.width / self.scale_x,
            rect.height / self.scale_y,
        )

    def translated(self, dx: float, dy: float) -> View:
        """The same view moved by (dx, dy) image px."""
        r = self.rect
        return replace(
            self, rect=Rect(r.x + dx * self.scale_x, r.y + dy * self.scale_y, r.width, r.height)
        )


@dataclass(frozen=True)
class PixelMap:
    """u_prev = sx * u + tx, v_prev = sy * v + ty: current image coordinates -> previous ones."""

    sx: float = 1.0
    sy: float = 1.0
    tx: float = 0.0
    ty: float = 0.0

    @property
    def is_translation(self) -> bool:
        return abs(self.sx - 1.0) < 1e-9 and abs(self.sy - 1.0) < 1e-9

    def shifted(self, dx: float, dy: float) -> PixelMap:
        """This map followed by a further shift of (dx, dy) current-image px."""
        return replace(self, tx=self.tx + self.sx * dx, ty=self.ty + self.sy * dy)


def relative_map(prev: View, curr: View) -> PixelMap:
    """The known map from the current image to the previous one, from the two views (option 1)."""
    return PixelMap(
        sx=curr.scale_x / prev.scale_x,
        sy=curr.scale_y / prev.scale_y,
        tx=(curr.rect.x - prev.rect.x) / prev.scale_x,
        ty=(curr.rect.y - prev.rect.y) / prev.scale_y,
    )


@dataclass(frozen=True)
class CameraIntrinsics:
    """A pinhole camera as CameraInfo.K gives it (px)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def of_camera_info(cls, info: Any) -> CameraIntrinsics:
        """From a sensor_msgs/CameraInfo (its size and K); ValueError when unusable."""
        k = info.k
        return cls(
            int(info.width), int(info.height), float(k[0]), float(k[4]), float(k[2]), float(k[5])
        )

    def __post_init__(self) -> None:
        values = (self.fx, self.fy, self.cx, self.cy)
        if not all(map(usable_value, values)) or self.fx <= 0 or self.fy <= 0:
            raise ValueError(
                f"camera intrinsics must be finite, within +-{MAX_MESSAGE_VALUE:g}, with fx, fy > 0,"
                f" got {values}"
            )
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"camera image size must be positive, got {self.width}x{self.height}")


def view_from_pan_tilt(
    pan: float, tilt: float, camera: CameraIntrinsics, scene: SceneGeometry
) -> View:
    """The scene rectangle a real pan-tilt camera sees at (pan, tilt) [rad].

    Each image edge is mapped through `camera_pixel_to_angles` (the ray's angles) and the scene's
    equiangular mapping, so the rectangle is exact along the image's centre lines. Scene x grows
    as pan decreases (pan positive = left).
    """
    if not (math.isfinite(pan) and math.isfinite(tilt)):
        raise ValueError(f"pan/tilt must be finite, got {pan}, {tilt}")

    def scene_point(u: float, v: float) -> tuple[float, float]:
        ray = camera_pixel_to_angles(u, v, pan, tilt, camera.fx, camera.fy, camera.cx, camera.cy)
        return scene.angles_to_pixel(*ray)

    left, _ = scene_point(0.0, camera.cy)
    right, _ = scene_point(float(camera.width), camera.cy)
    _, top = scene_point(camera.cx, 0.0)
    _, bottom = scene_point(camera.cx, float(camera.height))
    return View(Rect(left, top, right - left, bottom - top), camera.width, camera.height)


# --- alignment ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Alignment:
    """The two images resampled onto their common part, in current-image pixels."""

    prev: np.ndarray  # previous image over roi (resampled when the map is not an integer shift)
    curr: np.ndarray  # current image over roi (a view)
    roi: tuple[int, int, int, int]  # (x0, y0, x1, y1) current-image pixel range, end exclusive

    @property
    def area(self) -> int:
        x0, y0, x1, y1 = self.roi
        return (x1 - x0) * (y1 - y0)


def align(
    prev: np.ndarray, curr: np.ndarray, pixel_map: PixelMap, subpixel: bool = True
) -> Alignment | None:
    """Crop or resample both images onto their overlap; None when they do not overlap.

    An integer translation crops both images (no resampling, so SSIM sees the true pixels). A
    fractional translation is rounded when `subpixel` is False, else the previous image is
    resampled bilinearly, as is any map with a scale change (zoom).
    """
    m = pixel_map
    if m.is_translation:
        rx, ry = round(m.tx), round(m.ty)
        integral = abs(m.tx - rx) < INTEGER_TOLERANCE and abs(m.ty - ry) < INTEGER_TOLERANCE
        if integral or not subpixel:
            return _crop_aligned(prev, curr, rx, ry)
    return _resample_aligned(prev, curr, m)


def _crop_aligned(prev: np.ndarray, curr: np.ndarray, dx: int, dy: int) -> Alignment | None:
    (hp, wp), (hc, wc) = prev.shape[:2], curr.shape[:2]
    x0, x1 = max(0, -dx), min(wc, wp - dx)
    y0, y1 = max(0, -dy), min(hc, hp - dy)
    if x1 <= x0 or y1 <= y0:
        return None
    return Alignment(
        prev[y0 + dy : y1 + dy, x0 + dx : x1 + dx], curr[y0:y1, x0:x1], (x0, y0, x1, y1)
    )


def _resample_aligned(prev: np.ndarray, curr: np.ndarray, m: PixelMap) -> Alignment | None:
    # Current pixel j (centre j + 0.5) samples the previous image at index s * (j + 0.5) + t - 0.5;
    # keep the pixels whose sample lies inside the previous image's pixel centres (bilinear).
    (hp, wp), (hc, wc) = prev.shape[:2], curr.shape[:2]

    def index_range(s: float, t: float, n_prev: int, n_curr: int) -> tuple[int, int, float]:
        offset = 0.5 * s + t - 0.5
        lo = max(0, math.ceil((0.0 - offset) / s - 1e-9))
        hi = min(n_curr, math.floor((n_prev - 1 - offset) / s + 1e-9) + 1)
        return lo, hi, offset

    x0, x1, ox = index_range(m.sx, m.tx, wp, wc)
    y0, y1, oy = index_range(m.sy, m.ty, hp, hc)
    if x1 <= x0 or y1 <= y0:
        return None
    matrix = np.array([[m.sx, 0.0, m.sx * x0 + ox], [0.0, m.sy, m.sy * y0 + oy]])
    warped = cv2.warpAffine(
        prev,
        matrix,
        (x1 - x0, y1 - y0),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return Alignment(warped, curr[y0:y1, x0:x1], (x0, y0, x1, y1))


# --- shift estimators --------------------------------------------------------------------------


@dataclass(frozen=True)
class ShiftEstimate:
    """An estimated shift (image px, convention in the module docstring) and its quality."""

    dx: float
    dy: float
    score: float  # mean simplified SSIM at the best shift, or the phase-correlation peak height


def ssim_shift_search(
    prev: np.ndarray,
    curr: np.ndarray,
    radius: int = 30,
    window: int = 5,
    prior: tuple[int, int] = (0, 0),
    pyramid_levels: int = 0,
    subpixel: bool = False,
    params: SsimParams | None = None,
    min_overlap: float = 0.25,
) -> ShiftEstimate:
    """The seed's registration: the shift within `prior` +- `radius` maximising the simplified SSIM.

    Every candidate shift is scored by the mean simplified SSIM (`ssim.simplified_ssim`, uniform
    `window`) over the overlap of the two images, as the seed's correccion_desplazamiento.m does
    (its range -28..+29 becomes a symmetric +-radius). Shifts leaving less than `min_overlap` of
    the image are skipped. pyramid_levels = 0 is the seed's exhaustive search; n > 0 searches
    exhaustively on images downsampled 2^n times and refines by +-2 px at each finer level
    (much faster, same result on textured scenes). subpixel adds a parabola fit to the peak.
    """
    if radius < 0 or pyramid_levels < 0:
        raise ValueError(f"radius and pyramid_levels must be >= 0, got {radius}, {pyramid_levels}")
    if prev.shape != curr.shape:
        raise ValueError(f"images differ in size: {prev.shape} vs {curr.shape}")
    p = params or SsimParams()
    levels = _usable_levels(prev.shape, pyramid_levels, window)
    pyramid_prev, pyramid_curr = _pyramid(prev, levels), _pyramid(curr, levels)
    scale = 2**levels
    centre = (round(prior[0] / scale), round(prior[1] / scale))
    reach = math.ceil(radius / scale)
    lo = (int(prior[0]) - radius, int(prior[1]) - radius)
    hi = (int(prior[0]) + radius, int(prior[1]) + radius)
    best, scores = (0, 0), {}
    for level in range(levels, -1, -1):
        scorer = _ShiftScorer(
            box_statistics(pyramid_prev[level], window),
            box_statistics(pyramid_curr[level], window),
            p,
            min_overlap,
        )
        lvl_scale = 2**level
        candidates = [
            (centre[0] + i, centre[1] + j)
            for j in range(-reach, reach + 1)
            for i in range(-reach, reach + 1)
            if lo[0] <= (centre[0] + i) * lvl_scale <= hi[0]
            and lo[1] <= (centre[1] + j) * lvl_scale <= hi[1]
        ]
        scores = {shift: scorer.score(*shift) for shift in candidates}
        best = max(scores, key=lambda s: (scores[s], -abs(s[0]) - abs(s[1])))
        centre, reach = (2 * best[0], 2 * best[1]), 2
    dx, dy = float(best[0]), float(best[1])
    if subpixel:
        dx += _parabola_offset(
            scores.get((best[0] - 1, best[1])), scores[best], scores.get((best[0] + 1, best[1]))
        )
        dy += _parabola_offset(
            scores.get((best[0], best[1] - 1)), scores[best], scores.get((best[0], best[1] + 1))
        )
    return ShiftEstimate(dx, dy, float(scores[best]))


def _usable_levels(shape: tuple[int, ...], wanted: int, window: int) -> int:
    levels = 0
    while levels < wanted and min(shape[:2]) // 2 ** (levels + 1) >= 4 * window:
        levels += 1
    return levels


def _pyramid(image: np.ndarray, levels: int) -> list[np.ndarray]:
    out: list[np.ndarray] = [np.asarray(image, dtype=np.float32)]
    for _ in range(levels):
        out.append(cv2.pyrDown(out[-1]))
    return out


def _parabola_offset(left: float | None, centre: float, right: float | None) -> float:
    if left is None or right is None or not (np.isfinite(left) and np.isfinite(right)):
        return 0.0
    curvature = left - 2.0 * centre + right
    if curvature >= 0.0:
        return 0.0
    return float(np.clip(0.5 * (left - right) / curvature, -0.5, 0.5))


class _ShiftScorer:
    """Mean simplified SSIM over the overlap for one shift, with the per-image terms precomputed.

    score = 4 (ma mb + C1/2)(sa sb + C2/2) / ((ma^2 + C1/2 + mb^2 + C1/2)(sa^2 + C2/2 + sb^2 + C2/2)),
    which is `ssim.simplified_ssim` rearranged so each shift costs ten OpenCV passes.
    """

    def __init__(
        self, prev: BoxStatistics, curr: BoxStatistics, params: SsimParams, min_overlap: float
    ) -> None:
        half_c1, half_c2 = params.c1 / 2.0, params.c2 / 2.0
        self.prev = (prev.mean, prev.std, prev.mean**2 + half_c1, prev.std**2 + half_c2)
        self.curr = (curr.mean, curr.std, curr.mean**2 + half_c1, curr.std**2 + half_c2)
        self.half_c1, self.half_c2 = half_c1, half_c2
        self.min_area = min_overlap * curr.mean.size

    def score(self, dx: int, dy: int) -> float:
        h, w = self.curr[0].shape
        x0, x1 = max(0, -dx), min(w, w - dx)
        y0, y1 = max(0, -dy), min(h, h - dy)
        area: int = (x1 - x0) * (y1 - y0)
        if x1 <= x0 or y1 <= y0 or area < self.min_area:
            return -math.inf
        mp, sp, qp, vp = (a[y0 + dy : y1 + dy, x0 + dx : x1 + dx] for a in self.prev)
        mc, sc, qc, vc = (a[y0:y1, x0:x1] for a in self.curr)
        lum: np.ndarray = cv2.multiply(mp, mc)
        lum += self.half_c1
        con: np.ndarray = cv2.multiply(sp, sc)
        con += self.half_c2
        cv2.multiply(lum, con, dst=lum)
        den = cv2.multiply(cv2.add(qp, qc), cv2.add(vp, vc))
        return 4.0 * float(cv2.sumElems(cv2.divide(lum, den, dst=lum))[0]) / area


def phase_correlation_shift(
    prev: np.ndarray,
    curr: np.ndarray,
    prior: tuple[int, int] = (0, 0),
    candidates: int = 5,
    window: int = 5,
    params: SsimParams | None = None,
) -> ShiftEstimate:
    """Shift by phase correlation (Hann-windowed), verified by the simplified SSIM.

    Whitening makes every frequency count alike, so a small, sharply textured moving object
    can out-peak a smooth background. The `candidates` highest local peaks of the correlation
    surface are therefore scored like `ssim_shift_search` scores a shift, the best one kept and
    refined to sub-pixel by a parabola through the surface. The images are first cropped to
    their overlap at the integer `prior` shift, so the estimate is the residual around it
    (shifts beyond half the overlap alias). score is the chosen peak's height in the normalised
    correlation surface (1 for a pure translation, ~0 for unrelated images).
    """
    if prev.shape != curr.shape:
        raise ValueError(f"images differ in size: {prev.shape} vs {curr.shape}")
    if candidates < 1:
        raise ValueError(f"candidates must be >= 1, got {candidates}")
    px, py = int(prior[0]), int(prior[1])
    overlap = _crop_aligned(prev, curr, px, py)
    if overlap is None or min(overlap.prev.shape) < max(8, 2 * window):
        raise ValueError(f"prior shift {prior} leaves no usable overlap for {prev.shape} images")
    a = np.asarray(overlap.prev, dtype=np.float32)
    b = np.asarray(overlap.curr, dtype=np.float32)
    surface = _correlation_surface(a, b)
    h, w = surface.shape
    peaks = _highest_peaks(surface, candidates)
    if len(peaks) > 1:
        scorer = _ShiftScorer(
            box_statistics(a, window),
            box_statistics(b, window),
            params or SsimParams(),
            min_overlap=0.25,
        )
        peaks.sort(key=lambda p: -scorer.score(_wrapped(p[1], w), _wrapped(p[0], h)))
    iy, ix = peaks[0]
    peak = float(surface[iy, ix])
    fx = _parabola_offset(surface[iy, (ix - 1) % w], peak, surface[iy, (ix + 1) % w])
    fy = _parabola_offset(surface[(iy - 1) % h, ix], peak, surface[(iy + 1) % h, ix])
    return ShiftEstimate(px + _wrapped(ix, w) + fx, py + _wrapped(iy, h) + fy, peak)


def _correlation_surface(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Normalised cross-power spectrum, back in space: peaks at shifts d with b(p) ~ a(p + d)."""
    size = (scipy.fft.next_fast_len(a.shape[0], True), scipy.fft.next_fast_len(a.shape[1], True))
    cross = _windowed_spectrum(a, size)
    cross *= np.conj(_windowed_spectrum(b, size))
    cross /= np.abs(cross) + np.float32(1e-12)
    surface: np.ndarray = scipy.fft.irfft2(cross, s=size)
    return surface


def _highest_peaks(surface: np.ndarray, count: int) -> list[tuple[int, int]]:
    """(row, col) of the `count` highest local maxima (3x3, wrapping around), highest first."""
    if count == 1:  # the highest value is always a local maximum
        row, col = np.unravel_index(int(np.argmax(surface)), surface.shape)
        return [(int(row), int(col))]
    wrapped = cv2.copyMakeBorder(surface, 1, 1, 1, 1, cv2.BORDER_WRAP)
    is_peak = surface >= cv2.dilate(wrapped, np.ones((3, 3), np.uint8))[1:-1, 1:-1]
    rows, cols = np.nonzero(is_peak)
    order = np.argsort(surface[rows, cols])[::-1][:count]
    return [(int(rows[i]), int(cols[i])) for i in order]


def _wrapped(index: int, size: int) -> int:
    """A circular correlation index as a signed shift."""
    return index if index <= size // 2 else index - size


def _windowed_spectrum(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Real DFT of the mean-free, Hann-windowed image, zero-padded to `size` (a fast DFT size)."""
    h, w = image.shape
    padded = np.zeros(size, np.float32)
    cv2.multiply(image - float(image.mean()), _hann(image.shape), dst=padded[:h, :w])
    spectrum: np.ndarray = scipy.fft.rfft2(padded)
    return spectrum


@lru_cache(maxsize=8)
def _hann(shape: tuple[int, int]) -> np.ndarray:
    return cv2.createHanningWindow((shape[1], shape[0]), cv2.CV_32F)
