"""Structural similarity (SSIM) maps, fast, for motion detection (seed 000 §2; no rclpy).

`ssim_map` is Wang et al.'s SSIM index exactly as their reference code computes it (Gaussian
11x11 window, sigma 1.5, K1 0.01, K2 0.03, biased local statistics E[x^2] - mu^2), optionally
with Wang's automatic downsampling. It runs on OpenCV's separable float32 filters and in-place
arithmetic, over 20x faster than scikit-image's implementation on one core and equal to it to
~1e-5 (bench/bench_detect.py measures both).

`box_statistics` and `simplified_ssim` are the seed's "simplified SSIM" used for registration:
luminance x contrast only (no covariance), uniform window, statistics computed once per image.

Images are (H, W) arrays of grey levels (any real dtype); maps are float32.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

K1 = 0.01
K2 = 0.03
WIN_SIZE = 11
SIGMA = 1.5
_THREAD_BUFFERS = threading.local()
_WORKSPACE_SHAPES = 4  # image sizes whose buffers a thread keeps


@dataclass(frozen=True)
class SsimParams:
    """Constants of the SSIM index (Wang et al. 2004, defaults of their reference code)."""

    data_range: float = 255.0  # L, dynamic range of the pixel values
    k1: float = K1
    k2: float = K2
    win_size: int = WIN_SIZE  # odd side of the Gaussian window
    sigma: float = SIGMA  # std of the Gaussian window, px

    def __post_init__(self) -> None:
        if not (self.data_range > 0 and self.k1 > 0 and self.k2 > 0 and self.sigma > 0):
            raise ValueError(f"SSIM constants must be positive: {self}")
        if self.win_size < 3 or self.win_size % 2 == 0:
            raise ValueError(f"win_size must be odd and >= 3, got {self.win_size}")

    @property
    def c1(self) -> float:
        return (self.k1 * self.data_range) ** 2

    @property
    def c2(self) -> float:
        return (self.k2 * self.data_range) ** 2

    @property
    def border(self) -> int:
        """Pixels lost on each side by 'valid' filtering."""
        return self.win_size // 2


def gaussian_window(win_size: int = WIN_SIZE, sigma: float = SIGMA) -> np.ndarray:
    """The normalised 1-D Gaussian (win_size,) float32 whose outer product is fspecial's window."""
    return cv2.getGaussianKernel(win_size, sigma, cv2.CV_32F).ravel()


def auto_downsample_factor(shape: tuple[int, ...]) -> int:
    """Wang's automatic downsampling factor f = max(1, round(min(M, N) / 256))."""
    # MATLAB's round() rounds halves away from zero; Python's round() would round them to even.
    return max(1, int(np.floor(min(shape[:2]) / 256.0 + 0.5)))


def downsample(image: np.ndarray, factor: int) -> np.ndarray:
    """Wang's downsampling: f x f mean filter ('symmetric' borders), then every f-th pixel.

    The filter's anchor is MATLAB's kernel centre floor((f + 1) / 2), so for even f the output
    pixels are the means of disjoint f x f blocks. Returns float32.
    """
    img = np.asarray(image, dtype=np.float32)
    if factor <= 1:
        return img
    anchor = (factor + 1) // 2 - 1
    smoothed = cv2.blur(
        img, (factor, factor), anchor=(anchor, anchor), borderType=cv2.BORDER_REFLECT
    )
    return np.ascontiguousarray(smoothed[::factor, ::factor])


def ssim_map(
    x: np.ndarray,
    y: np.ndarray,
    params: SsimParams | None = None,
    *,
    valid: bool = False,
    downsample_factor: int = 1,
) -> np.ndarray:
    """The SSIM index map of two equal-size grey images.

    valid=False returns a map the size of the (downsampled) input, borders computed with
    mirrored ('reflect') padding as scikit-image does; valid=True returns only the pixels whose
    window lies inside the image, as Wang's filter2(..., 'valid'): `params.border` fewer on each
    side. downsample_factor > 1 first applies `downsample` (use `auto_downsample_factor` for
    Wang's automatic choice); the map is then in downsampled pixels.
    """
    p = params or SsimParams()
    if x.shape != y.shape or x.ndim != 2:
        raise ValueError(f"ssim_map needs two equal-size 2-D images, got {x.shape} and {y.shape}")
    if downsample_factor > 1:
        x, y = downsample(x, downsample_factor), downsample(y, downsample_factor)
    if min(x.shape) < p.win_size:
        raise ValueError(f"images of {x.shape} are smaller than the {p.win_size}px SSIM window")
    spare_x, spare_y, mu_x, mu_y, cross, sum_sq, diff = _workspace(x.shape)
    row, col = _window_taps(p.win_size, p.sigma)
    # Statistics of the images minus half their range: the float32 variances E[x^2] - mu^2 then
    # lose ~100x less to cancellation (the offset changes neither variances nor covariances).
    centre = p.data_range / 2.0
    if x.dtype == np.uint8 and y.dtype == np.uint8:
        _centred_products_8bit(x, y, centre, cross, sum_sq, diff)
        # Filtering 8-bit input is ~25 % faster; the filter's delta centres the means exactly.
        _blur_8bit(x, row, mu_x, -centre)
        _blur_8bit(y, row, mu_y, -centre)
    else:
        xs = np.subtract(x, centre, out=spare_x, dtype=np.float32)
        ys = np.subtract(y, centre, out=spare_y, dtype=np.float32)
        cv2.multiply(xs, ys, dst=cross)
        cv2.accumulateSquare(ys, cv2.multiply(xs, xs, dst=sum_sq))
        _blur(xs, row, col, mu_x)
        _blur(ys, row, col, mu_y)
    # SSIM needs only the sum of the two variances: E[x^2 + y^2] is one filter, not two.
    _blur(cross, row, col, cross)
    _blur(sum_sq, row, col, sum_sq)
    if valid:
        # Only the interior: every array is cut to the same view (OpenCV follows numpy strides).
        b = p.border
        mu_x, mu_y, cross, sum_sq, spare_y = (
            m[b:-b, b:-b] for m in (mu_x, mu_y, cross, sum_sq, spare_y)
        )
    return _combine(mu_x, mu_y, cross, sum_sq, spare_y, p, centre, np.empty(mu_x.shape, np.float32))


@lru_cache(maxsize=8)
def _window_taps(win_size: int, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """The Gaussian window as a (1, n) row and an (n, 1) column kernel, made once per window."""
    taps = gaussian_window(win_size, sigma)
    taps.flags.writeable = False  # shared by every call and thread
    return taps.reshape(1, -1), taps.reshape(-1, 1)


def _workspace(shape: tuple[int, int]) -> list[np.ndarray]:
    """Six float32 buffers and one uint8 buffer of `shape`, reused between calls of this thread.

    A 768x576 map needs ~11 MB of temporaries; allocating them afresh each call costs more in
    page faults than the arithmetic itself (they are above malloc's mmap threshold).
    """
    cache: OrderedDict[tuple[int, int], list[np.ndarray]] | None = getattr(
        _THREAD_BUFFERS, "by_shape", None
    )
    if cache is None:
        cache = _THREAD_BUFFERS.by_shape = OrderedDict()
    if shape not in cache:
        cache[shape] = [np.empty(shape, np.float32) for _ in range(6)] + [np.empty(shape, np.uint8)]
        while len(cache) > _WORKSPACE_SHAPES:
            cache.popitem(last=False)
    cache.move_to_end(shape)
    return cache[shape]


def _centred_products_8bit(
    x: np.ndarray,
    y: np.ndarray,
    c: float,
    cross: np.ndarray,
    sum_sq: np.ndarray,
    diff: np.ndarray,
) -> None:
    """cross = (x - c)(y - c) and sum_sq = (x - c)^2 + (y - c)^2 of 8-bit images, as float32.

    Straight from the 8-bit pixels (OpenCV's accumulate functions read uint8), without float
    copies of x and y: cross = xy - c (x + y) + c^2, and sum_sq = 2 cross + (x - y)^2 with
    |x - y| an 8-bit absolute difference. Four passes instead of six; for the usual c = 127.5
    every intermediate value is an exact float32, so the products are exact.
    """
    cv2.addWeighted(x, -c, y, -c, c * c, dst=cross, dtype=cv2.CV_32F)
    cv2.accumulateProduct(x, y, cross)
    cv2.add(cross, cross, dst=sum_sq)
    cv2.accumulateSquare(cv2.absdiff(x, y, dst=diff), sum_sq)


def _blur_8bit(img: np.ndarray, row: np.ndarray, dst: np.ndarray, delta: float) -> np.ndarray:
    """Gaussian-weighted local mean (plus `delta`) of an 8-bit image as float32, mirrored borders."""
    return cv2.sepFilter2D(
        img, cv2.CV_32F, row, row, dst=dst, delta=delta, borderType=cv2.BORDER_REFLECT
    )


def _blur(img: np.ndarray, row: np.ndarray, col: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Gaussian-weighted local mean of a float32 image, mirrored borders; `dst` may be `img`.

    Two 1-D filter2D passes: for float32 images OpenCV runs these ~10 % faster than one
    sepFilter2D (whose float32 row filter is slower than filter2D's).
    """
    cv2.filter2D(img, cv2.CV_32F, row, dst=dst, borderType=cv2.BORDER_REFLECT)
    return cv2.filter2D(dst, cv2.CV_32F, col, dst=dst, borderType=cv2.BORDER_REFLECT)


def _combine(
    mu_x: np.ndarray,
    mu_y: np.ndarray,
    cross: np.ndarray,
    sum_sq: np.ndarray,
    free: np.ndarray,
    p: SsimParams,
    c: float,
    out: np.ndarray,
) -> np.ndarray:
    """SSIM = (2 mx my + C1)(2 sxy + C2) / ((mx^2 + my^2 + C1)(sx^2 + sy^2 + C2)), into `out`.

    The inputs are local moments of the centred images (x - c, y - c); the true means are
    mu + c, so mx my = mu_x mu_y + c s + c^2 and mx^2 + my^2 = mu_x^2 + mu_y^2 + 2 c s + 2 c^2
    with s = mu_x + mu_y. Each line is one fused OpenCV pass, most of them in place (cheaper
    than writing a third array); all five input arrays are overwritten.
    """
    prod = cv2.multiply(mu_x, mu_y, dst=out)
    total = cv2.add(mu_x, mu_y, dst=free)
    sq = cv2.accumulateSquare(mu_y, cv2.multiply(mu_x, mu_x, dst=mu_x))
    num_contrast = cv2.addWeighted(cross, 2.0, prod, -2.0, p.c2, dst=cross)  # 2 cov + C2
    den_contrast = cv2.addWeighted(sum_sq, 1.0, sq, -1.0, p.c2, dst=sum_sq)  # var_x + var_y + C2
    num_lum = cv2.addWeighted(prod, 2.0, total, 2.0 * c, 2.0 * c * c + p.c1, dst=prod)
    den_lum = cv2.addWeighted(sq, 1.0, total, 2.0 * c, 2.0 * c * c + p.c1, dst=sq)
    num = cv2.multiply(num_lum, num_contrast, dst=num_lum)
    den = cv2.multiply(den_lum, den_contrast, dst=den_lum)
    return cv2.divide(num, den, dst=out)


def mean_ssim(x: np.ndarray, y: np.ndarray, params: SsimParams | None = None) -> float:
    """MSSIM as Wang's ssim.m returns it: automatic downsampling, mean of the 'valid' map."""
    factor = auto_downsample_factor(x.shape)
    return float(np.mean(ssim_map(x, y, params, valid=True, downsample_factor=factor)))


# --- the seed's simplified SSIM (registration) ------------------------------------------------


@dataclass(frozen=True)
class BoxStatistics:
    """Local means and standard deviations of an image under a uniform window ('valid' size)."""

    mean: np.ndarray  # float32
    std: np.ndarray  # float32, sqrt of the biased local variance
    window: int  # side of the uniform window, px

    @property
    def shape(self) -> tuple[int, int]:
        return self.mean.shape


def box_statistics(image: np.ndarray, window: int = 5) -> BoxStatistics:
    """Local mean and std over a uniform window x window ('valid'), the seed's filter2(ones/25)."""
    if window < 1:
        raise ValueError(f"window must be >= 1, got {window}")
    img = np.asarray(image, dtype=np.float32)
    if min(img.shape) < window:
        raise ValueError(f"image of {img.shape} is smaller than the {window}px window")
    mean = cv2.blur(img, (window, window), borderType=cv2.BORDER_REFLECT)
    mean_sq = cv2.blur(cv2.multiply(img, img), (window, window), borderType=cv2.BORDER_REFLECT)
    b = window // 2
    hi_r, hi_c = img.shape[0] - (window - 1 - b), img.shape[1] - (window - 1 - b)
    mean, mean_sq = mean[b:hi_r, b:hi_c], mean_sq[b:hi_r, b:hi_c]
    var = cv2.subtract(mean_sq, cv2.multiply(mean, mean))
    np.maximum(var, 0.0, out=var)  # float32 cancellation can leave tiny negatives
    return BoxStatistics(np.ascontiguousarray(mean), np.sqrt(var), window)


def simplified_ssim(
    mean_a: np.ndarray,
    std_a: np.ndarray,
    mean_b: np.ndarray,
    std_b: np.ndarray,
    params: SsimParams | None = None,
) -> np.ndarray:
    """Luminance x contrast map (2 ma mb + C1)(2 sa sb + C2) / ((ma^2 + mb^2 + C1)(sa^2 + sb^2 + C2)).

    The seed's registration score (thesis §5.2, "SSIM simplificado"): SSIM without the
    covariance, so its statistics need computing once per image, not once per shift.
    """
    p = params or SsimParams()
    # cv2 returns float32 arrays here (its stubs say 'integer or floating')
    num: np.ndarray = cv2.multiply(mean_a, mean_b, scale=2.0)
    num += p.c1
    contrast: np.ndarray = cv2.multiply(std_a, std_b, scale=2.0)
    contrast += p.c2
    cv2.multiply(num, contrast, dst=num)
    den: np.ndarray = cv2.add(cv2.multiply(mean_a, mean_a), cv2.multiply(mean_b, mean_b))
    den += p.c1
    var_sum: np.ndarray = cv2.add(cv2.multiply(std_a, std_a), cv2.multiply(std_b, std_b))
    var_sum += p.c2
    cv2.multiply(den, var_sum, dst=den)
    return cv2.divide(num, den, dst=num)
