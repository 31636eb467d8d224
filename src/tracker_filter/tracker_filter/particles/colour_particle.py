"""Seed 003's colour-histogram SIR particle filter (Rodríguez Moya 2009, after Bagdanov et al.
2007) with its extensions, one filter per target, no rclpy.

State (eq. 34), per particle: [x y w h vx vy vw vh], the rectangle's top-left corner, width and
height and their rates, in px and px per frame. Each frame (`ColourParticleFilter.step`):

    propagate  x_t = A x_{t-1} + v,  A = [[I4, I4], [0, I4]],  v ~ N(0, diag(sigma^2))   (eq. 36)
    weigh      w_i = similarity of particle i's rectangle to the reference (the appearance)
    correct    w_i <- c(w_i)   (Ext 1: linear, sigmoid or exponential; none in the baseline)
    estimate   the weighted mean sum_i w_i x_i / sum_i w_i   (or the best particle)
    resample   N particles drawn by weight (multinomial as the thesis's pseudocode, or systematic)

Ext 2 (adaptive noise): with s the similarity of the previous estimate to the reference,
zeta = [erf(alpha ((1 - s) - beta)) + 1] / 2 and the static components' std (x y w h) is
zeta sigma, the dynamic ones' (1 - zeta) sigma: a good match moves the particles by their
velocities only, a lost one spreads them in place (a search).

Occlusion (not the thesis's; off by default): with `occlusion_ratio` r > 0, a frame whose best
particle scores below r x the tracked level (a running mean of the best score over the frames
where the target was seen) is taken as the target hidden. Its scores say nothing about the
target, and resampling by them would pull the cloud onto whatever is in front (the thesis's filter
stops at the occluder's edge), so the particles are not weighed or resampled: they coast on
their velocities, with noise on every component (not Ext 2's share, which would freeze the
velocities), so the cloud spreads along the way the target was going, wider the longer it is
hidden, until a particle finds the target again. `coast_noise` c scales that noise to c sigma,
and the particles' velocities about the velocity seen to c times their spread when the target
went out of sight: a sigma wide enough to follow a walker's stride and perspective spreads the
cloud in a second of coasting over a region where a passer-by or the background outscores the
target when it comes out. Given the motion detector's foreground mask (below), two more switches:
`reappear_in_mask` lets only a box the mask holds end a hidden spell (the occluder, or the
street behind it, may match the reference, but does not move), and `probes` P > 0 adds, on each
hidden frame, up to P particles at the target's size where the mask holds such a box within
`probe_reach` x its height of the cloud's centre (the best of 8 P random places; the mixture
proposal of Okuma et al.'s boosted particle filter, with the mask as the detector): someone who
comes out off the way they went in is found when they are back in sight, not when the cloud's
spread has grown to reach them. Probes that find nothing are dropped.
`settle_frames` N > 0: the target is never taken as hidden in its first N frames, as the level
starts at the start frame's own match, which a walker's next steps rarely reach, and a cloud
started at rest is still catching up with them. `coast_perspective`: a hidden target's boxes are
also rescaled about their bottom centre as they coast, by the expected height (`height`, below)
at their new bottom row over that at the old (`in_perspective`): a person walking away from the
camera behind a board comes out smaller than they went in, and a cloud that kept their old size
was twice their width when they did. `height_before_line`: until a ground line is learned (the
step is given no `height`), the height prior expects the target's start height wherever a box
stands (a flat line through the start box): early in a scene a person whose legs the mask loses,
or who walks behind a low board, would otherwise be followed by a box shrinking onto their head.
`upper_share` u > 0: a person behind a board up to their chest, or coming out over one, shows
only head and shoulders; the whole box's match falls below the hidden test's share of its level,
and the cloud either coasts (on at the speed they went in, while they slow, turn or stop in
sight) or, matched by the background-weighted colours above the board, climbs off them. The
filter also keeps a reference of the start box's top u (taken the same way, by a copy of the
appearance) and the level of the estimate's top part while the target is seen whole. On a frame
that would take the target as hidden, the particles' top parts are scored against it (only
those the foreground mask holds, when there is one: a part in sight moves, the board in front of
the rest does not); if the best reaches `occlusion_ratio` x that level (the level itself for a
target hidden the frame before: a part is less telling than the whole), the frame is weighed and
resampled by the top parts instead (without the foreground cue, which would shrink the box onto
the part in the mask; the height prior keeps the whole box's size). The estimate is then
`partial`: its box is the part in sight (cut where its blobs in the mask end, at least the top
u), its similarity the top part's on the whole's scale (x the whole's level over the part's).

Scale (not the thesis's; off by default): `foreground` (`foreground_cue`) multiplies each weight by
how well the particle's box bounds the motion detector's foreground mask, on the frames whose step
is given one, and on those frames `size_noise` s > 0 also scales each particle's width and height
by exp(N(0, s^2)) about its centre. A colour histogram alone cannot tell a box shrunk inside the
person from the right one, so the thesis keeps the size nearly fixed (0.125 px per frame, which
Ext 2 turns off while the match is good); with the mask to hold it, the size can follow a
walker's perspective and stride; with the cue's `fit` > 0 the reported box is also pulled
toward the box of the mask's blobs it holds (the cloud is not). The mask loses legs on grey
ground and holds two people walking together: `height_spread` > 0 then also multiplies each
weight by a prior on the box's height, exp(-(ln(h / h_expected) / spread)^2 / 2), where
h_expected is the height the target has where the box stands (`object_scale.ExpectedHeight`:
the ground line learned from the tracks, scaled through the target's own boxes), given to each
step; `aspect_spread` > 0 adds a one-sided prior on the box's width for its height when the
expected height knows how wide one object usually is (`ExpectedHeight.likelihood`): a person
walking half behind another is one blob with them, and the cue's recall would widen the box
over both.

The reference is taken from the start rectangle and never updated, as in the thesis. Every random
draw comes from the filter's own `numpy.random.Generator`, so a run is reproducible.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol

import numpy as np
from scipy.special import erf

from tracker_filter.colour_histograms import (
    ColourSpace,
    bin_count,
    bin_image,
    clip_bounds,
    coefficients,
    histogram,
    ring_coefficients,
)
from tracker_filter.object_scale import ExpectedHeight
from tracker_filter.particles.foreground_cue import ForegroundCue, ForegroundMask, blob_box
from tracker_filter.particles.region_covariance import (
    forstner_distances,
    integral_features,
    region_covariances,
)
from tracker_msgs_py.histograms import background_weights
from tracker_msgs_py.params import check_config

STATE = ("x", "y", "w", "h", "vx", "vy", "vw", "vh")
#: the thesis's recommended noise std per state component (px, px per frame)
RECOMMENDED_SIGMA = (0.5, 0.5, 0.125, 0.125, 0.25, 0.25, 0.0002, 0.0002)
MIN_SIDE = 2.0  # px: a particle's rectangle never shrinks below this
LEVEL_GAIN = 0.1  # of the tracked level's running mean, per frame seen
PROBE_CANDIDATES = 8  # boxes drawn per probe kept


class Resampling(StrEnum):
    MULTINOMIAL = "multinomial"
    SYSTEMATIC = "systematic"


class EstimateRule(StrEnum):
    MEAN = "mean"  # the weighted mean (the thesis)
    BEST = "best"  # the particle of largest weight


class WeightCorrection(StrEnum):
    NONE = "none"
    LINEAR = "linear"
    SIGMOID = "sigmoid"
    EXPONENTIAL = "exponential"


@dataclass(frozen=True)
class ParticleFilterConfig:
    """Parameters; the defaults are the thesis's final algorithm (Ext 1 sigmoid + Ext 2)."""

    particles: int = 750
    sigma: tuple[float, ...] = RECOMMENDED_SIGMA
    resampling: Resampling = Resampling.MULTINOMIAL
    estimate: EstimateRule = EstimateRule.MEAN
    correction: WeightCorrection = WeightCorrection.SIGMOID
    sigmoid_alpha: float = 8.0
    sigmoid_beta: float = 0.5
    exponential_lambda: float = 10.0
    adaptive_noise: bool = True
    noise_alpha: float = 20.0
    noise_beta: float = 0.7
    occlusion_ratio: float = 0.0  # not the thesis's: 0 = off (see the module docstring)
    size_noise: float = 0.0  # not the thesis's: relative std of w and h per frame (0 = off)
    foreground: ForegroundCue = ForegroundCue()  # not the thesis's: off (power 0)
    # not the thesis's: std of ln(box height / the height expected where it stands) (0 = off)
    height_spread: float = 0.0
    # not the thesis's: std of ln(box aspect / one object's usual aspect) above it (0 = off)
    aspect_spread: float = 0.0
    # not the thesis's: the cloud's randomness while the target is hidden, as a share of what it
    # is while seen (the noise std, the velocities' spread)
    coast_noise: float = 1.0
    # not the thesis's: boxes proposed on each hidden frame where the foreground mask moves near
    # the coasting cloud (0 = off), within `probe_reach` x the target's height of its centre
    probes: int = 0
    probe_reach: float = 1.0
    # not the thesis's: a hidden target is back only in a box the foreground mask holds
    reappear_in_mask: bool = False
    # not the thesis's: the target is never taken as hidden in its first frames (0 = from the
    # first): the tracked level is still the start frame's own match, which a walker's next
    # steps do not reach, and a cloud started at rest is still catching up with them
    settle_frames: int = 0
    # not the thesis's: a hidden target's boxes keep the ground line's perspective as they coast
    # (scaled by the expected height at their new bottom row over that at the old; needs the
    # height prior's `height` in `step`)
    coast_perspective: bool = False
    # not the thesis's: with the height prior, before a ground line is known the target's start
    # height is expected wherever its box stands
    height_before_line: bool = False
    # not the thesis's: a target whose whole box matches worse than the top `upper_share` of it
    # does (someone behind a low board, or coming out over one) is followed by that part, with
    # a reference of its own (0 = off)
    upper_share: float = 0.0

    def problems(self) -> list[str]:
        """What is wrong with these values (empty when usable)."""
        checks = {
            "particles must be >= 1": self.particles >= 1,
            "sigma needs 8 values >= 0": len(self.sigma) == len(STATE)
            and all(math.isfinite(s) and s >= 0 for s in self.sigma),
            "sigmoid_alpha must be > 0": self.sigmoid_alpha > 0,
            "exponential_lambda must be > 0": self.exponential_lambda > 0,
            "noise_alpha must be > 0": self.noise_alpha > 0,
            "occlusion_ratio must be in [0, 1)": 0.0 <= self.occlusion_ratio < 1.0,
            "size_noise must be in [0, 1]": 0.0 <= self.size_noise <= 1.0,
            "height_spread must be >= 0": math.isfinite(self.height_spread)
            and self.height_spread >= 0.0,
            "aspect_spread must be >= 0": math.isfinite(self.aspect_spread)
            and self.aspect_spread >= 0.0,
            "coast_noise must be in [0, 1]": 0.0 <= self.coast_noise <= 1.0,
            "probes must be >= 0": self.probes >= 0,
            "probe_reach must be > 0": math.isfinite(self.probe_reach) and self.probe_reach > 0,
            "settle_frames must be >= 0": self.settle_frames >= 0,
            "upper_share must be in [0, 1)": 0.0 <= self.upper_share < 1.0,
        }
        return [message for message, ok in checks.items() if not ok]

    def __post_init__(self) -> None:
        object.__setattr__(self, "resampling", Resampling(self.resampling))
        object.__setattr__(self, "estimate", EstimateRule(self.estimate))
        object.__setattr__(self, "correction", WeightCorrection(self.correction))
        object.__setattr__(self, "sigma", tuple(float(s) for s in self.sigma))
        check_config(self)


def corrected_weights(weights: np.ndarray, config: ParticleFilterConfig) -> np.ndarray:
    """Ext 1, applied to the raw similarities before the estimate and resampling:

    linear       w' = 0.9 (w - min) / (max - min) + 0.1   (all 1 when max = min)
    sigmoid      w' = [erf(alpha (w - beta)) + 1] / 2      (alpha 8, beta 0.5: 0.61 -> 0.893)
    exponential  w' = exp(-lambda (1 - w))
    """
    rule = config.correction
    if rule is WeightCorrection.NONE:
        return weights
    if rule is WeightCorrection.LINEAR:
        low, high = float(weights.min()), float(weights.max())
        if high <= low:
            return np.ones_like(weights)
        return 0.9 * (weights - low) / (high - low) + 0.1
    if rule is WeightCorrection.SIGMOID:
        sigmoid: np.ndarray = (
            erf(config.sigmoid_alpha * (weights - config.sigmoid_beta)) + 1.0
        ) / 2.0
        return sigmoid
    return np.exp(-config.exponential_lambda * (1.0 - weights))


def static_noise_share(similarity: float, alpha: float = 20.0, beta: float = 0.7) -> float:
    """Ext 2's zeta = [erf(alpha ((1 - s) - beta)) + 1] / 2 (0.4 -> 0.002, 0.3 -> 0.5, 0.2 -> 0.998)."""
    return (math.erf(alpha * ((1.0 - similarity) - beta)) + 1.0) / 2.0


def propagate(
    particles: np.ndarray, sigma: np.ndarray, rng: np.random.Generator, size_noise: float = 0.0
) -> np.ndarray:
    """Eq. 36 with one frame's step: position and size move by their rates, plus noise; with
    `size_noise` s > 0, each box is then also scaled by exp(N(0, s^2)) per side about its centre."""
    moved = particles.copy()
    moved[:, :4] += particles[:, 4:]
    moved += rng.standard_normal(particles.shape) * sigma
    if size_noise > 0:
        centres = moved[:, :2] + moved[:, 2:4] / 2
        moved[:, 2:4] *= np.exp(rng.standard_normal((len(moved), 2)) * size_noise)
        moved[:, :2] = centres - moved[:, 2:4] / 2
    moved[:, 2:4] = np.maximum(moved[:, 2:4], MIN_SIDE)
    return moved


def resample(
    weights: np.ndarray, rule: Resampling, rng: np.random.Generator, count: int | None = None
) -> np.ndarray:
    """Indices of the `count` particles kept (default: as many as there are weights), drawn
    with probability proportional to `weights`: multinomial (one uniform draw per particle
    through the inverse CDF) or systematic (one draw, `count` equally spaced points)."""
    n = len(weights) if count is None else count
    cdf = np.cumsum(weights)
    cdf /= cdf[-1]
    multinomial = rule is Resampling.MULTINOMIAL
    points = rng.random(n) if multinomial else (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cdf, points, side="right"), len(weights) - 1)


class Appearance(Protocol):
    """What a particle's rectangle is compared by: a reference taken once, similarities in [0, 1]."""

    def reference(self, image: np.ndarray, box: np.ndarray) -> None:
        """Takes the reference from `box` (x, y, w, h) of the bgr8 `image`."""

    def similarities(self, image: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Similarity of each box (N, 4) to the reference; 1 = identical."""


#: The contrast cue's ring is sampled every 2nd row and column: a quarter of its cost, and its
#: histogram only has to tell person from background.
RING_STRIDE = 2


@dataclass
class HistogramAppearance:
    """Colour histogram(s) and the Bhattacharyya coefficient (the baseline, Ext 3 and Ext 4).

    `regions` > 1 splits the rectangle into that many horizontal bands of equal height, each with
    its own reference; the similarity is the product of their coefficients (Ext 4: 3 regions).

    `background_weighting` (not the thesis's): the reference is Comaniciu's background-weighted
    histogram, bin u scaled by min(o* / o_u, 1) with o the histogram of the start box's
    surroundings (the box grown by `background_margin` x its size per side), then normalised. A
    person's box is mostly background; without this, every box near them scores 0.7-0.9.

    `contrast` (not the thesis's): a scale cue. A colour histogram scores a box shrunk inside the
    person as well as the right one, so a box's coefficient is multiplied by
        (1 - contrast * rho_ring) ^ contrast_power
    with rho_ring the coefficient against the (whole-box) reference of the ring around it (the box
    grown by `contrast_margin` x its size per side): a box inside the person has the person around
    it, the right one the background; a box too large loses its own coefficient."""

    space: ColourSpace = ColourSpace.RGB
    bins: int = 16
    regions: int = 1
    background_weighting: bool = False
    background_margin: float = 1.0
    contrast: float = 0.0
    contrast_margin: float = 0.2
    contrast_power: float = 2.0
    _sqrt_references: np.ndarray | None = None
    _sqrt_whole: np.ndarray | None = None

    def _bands(self, boxes: np.ndarray) -> np.ndarray:
        """Each box's `regions` bands, box by box: (N * regions, 4)."""
        bands = np.repeat(boxes, self.regions, axis=0).astype(float)
        band_height = bands[:, 3] / self.regions
        bands[:, 1] += np.tile(np.arange(self.regions), len(boxes)) * band_height
        bands[:, 3] = band_height
        return bands

    def reference(self, image: np.ndarray, box: np.ndarray) -> None:
        bins_of_pixels = bin_image(image, self.space, self.bins)
        count = bin_count(self.space, self.bins)
        bounds = clip_bounds(self._bands(np.asarray(box, float)[None]), image.shape)
        hists = np.stack([histogram(bins_of_pixels, b, count) for b in bounds])
        if np.any(hists.sum(axis=1) == 0):
            raise ValueError(f"the reference box {box} holds no pixels of the image")
        if self.background_weighting:
            hists = hists * background_weights(self._surroundings(bins_of_pixels, box, count))
            hists /= np.maximum(hists.sum(axis=1, keepdims=True), 1e-12)
        self._sqrt_references = np.sqrt(hists)
        self._sqrt_whole = np.sqrt(hists.mean(axis=0))  # the bands have equal pixel counts

    def _surroundings(self, bins_of_pixels: np.ndarray, box: np.ndarray, count: int) -> np.ndarray:
        """Pixel counts per bin of the ring around `box` (grown by background_margin x its size
        per side, without the box)."""
        x, y, w, h = (float(v) for v in box)
        grown = np.array(
            [
                [
                    x - self.background_margin * w,
                    y - self.background_margin * h,
                    w * (1 + 2 * self.background_margin),
                    h * (1 + 2 * self.background_margin),
                ],
                [x, y, w, h],
            ]
        )
        outer, inner = clip_bounds(grown, bins_of_pixels.shape)

        def counts(b: np.ndarray) -> np.ndarray:
            x0, y0, x1, y1 = (int(v) for v in b)
            return np.bincount(bins_of_pixels[y0:y1, x0:x1].ravel(), minlength=count)

        band: np.ndarray = (counts(outer) - counts(inner)).astype(float)
        return band

    def similarities(self, image: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        if self._sqrt_references is None or self._sqrt_whole is None:
            raise RuntimeError("similarities before a reference was taken")
        boxes = np.asarray(boxes, float)
        bounds = clip_bounds(self._bands(boxes), image.shape)
        rings = self._rings(boxes, image.shape) if self.contrast > 0 else None
        # bins of only the part the rectangles (and their rings, which hold them) cover
        x0, y0, x1, y1 = _covering(bounds if rings is None else rings)
        bins_of_pixels = bin_image(image[y0:y1, x0:x1], self.space, self.bins)
        shift = np.array([x0, y0, x0, y0])
        which = np.tile(np.arange(self.regions), len(boxes))
        rho: np.ndarray = coefficients(bins_of_pixels, bounds - shift, self._sqrt_references, which)
        rho = rho.reshape(len(boxes), self.regions).prod(axis=1)
        if rings is None:
            return rho
        inner = clip_bounds(boxes, image.shape) - shift
        rho_ring = ring_coefficients(
            bins_of_pixels, inner, rings - shift, self._sqrt_whole, RING_STRIDE
        )
        # (1 - contrast * rho_ring) ^ contrast_power (see the class docstring)
        contrasted: np.ndarray = (
            rho * np.clip(1.0 - self.contrast * rho_ring, 0.0, 1.0) ** self.contrast_power
        )
        return contrasted

    def _rings(self, boxes: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """The bounds of each box grown by `contrast_margin` x its size per side."""
        margin = self.contrast_margin
        grown = boxes + np.column_stack([-margin * boxes[:, 2:], 2 * margin * boxes[:, 2:]])
        return clip_bounds(grown, shape)


def top_parts(boxes: np.ndarray, share: float) -> np.ndarray:
    """The top `share` of each box (N, 4: x, y, w, h)."""
    tops = np.array(boxes, dtype=float)
    tops[:, 3] *= share
    return tops


def seen_part(mask: ForegroundMask, box: np.ndarray, margin: float, share: float) -> np.ndarray:
    """`box` (x, y, w, h) cut at the bottom where its blobs in the foreground `mask` end, but
    keeping at least its top `share`: the part in sight of a target followed by its top part;
    `box` when no blob is its."""
    blobs = blob_box(mask.mask, box, margin)
    if blobs is None:
        return box
    bottom = min(box[1] + box[3], max(blobs[1] + blobs[3], box[1] + share * box[3]))
    return np.array([box[0], box[1], box[2], max(bottom - box[1], MIN_SIDE)])


def _covering(bounds: np.ndarray) -> tuple[int, int, int, int]:
    """The smallest [x0, y0, x1, y1) holding all `bounds` (at least one pixel)."""
    x0, y0 = int(bounds[:, 0].min()), int(bounds[:, 1].min())
    x1, y1 = int(bounds[:, 2].max()), int(bounds[:, 3].max())
    return x0, y0, max(x1, x0 + 1), max(y1, y0 + 1)


@dataclass
class CovarianceAppearance:
    """Ext 5: the region covariance of [x y R G B] (`region_covariance`), compared by the Förstner
    distance rho and mapped to a similarity exp(-rho / scale) (the thesis leaves the mapping open;
    scale 1 is the digest's exp(-rho)). An empty rectangle has similarity 0."""

    scale: float = 1.0
    _reference: np.ndarray | None = None

    def reference(self, image: np.ndarray, box: np.ndarray) -> None:
        bounds = clip_bounds(np.asarray(box, float)[None], image.shape)
        if np.any(bounds[:, 2] <= bounds[:, 0]) or np.any(bounds[:, 3] <= bounds[:, 1]):
            raise ValueError(f"the reference box {box} holds no pixels of the image")
        self._reference = self._covariances(image, bounds)[0]

    @staticmethod
    def _covariances(image: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        x0, y0, x1, y1 = _covering(bounds)
        integral = integral_features(image[y0:y1, x0:x1])
        return region_covariances(integral, bounds - np.array([x0, y0, x0, y0]))

    def similarities(self, image: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        if self._reference is None:
            raise RuntimeError("similarities before a reference was taken")
        bounds = clip_bounds(boxes, image.shape)
        present = (bounds[:, 2] > bounds[:, 0]) & (bounds[:, 3] > bounds[:, 1])
        out = np.zeros(len(boxes))
        if present.any():
            rho = forstner_distances(self._covariances(image, bounds[present]), self._reference)
            out[present] = np.exp(-rho / self.scale)
        return out


def in_perspective(boxes: np.ndarray, before: np.ndarray, height: ExpectedHeight) -> np.ndarray:
    """Boxes (N, 4) that moved from `before` rescaled about their bottom centre by the expected
    height at their bottom row over that at their old one: an object walking away from the
    camera shrinks as its feet rise in the image, also while nothing of it is seen."""
    ratio = height.heights(boxes) / height.heights(before)
    out = boxes.copy()
    out[:, 2] = np.maximum(boxes[:, 2] * ratio, MIN_SIDE)
    out[:, 3] = np.maximum(boxes[:, 3] * ratio, MIN_SIDE)
    out[:, 0] = boxes[:, 0] + 0.5 * (boxes[:, 2] - out[:, 2])
    out[:, 1] = boxes[:, 1] + (boxes[:, 3] - out[:, 3])
    return out


@dataclass(frozen=True)
class ParticleEstimate:
    box: np.ndarray  # x, y, w, h (px)
    velocity: np.ndarray  # vx, vy, vw, vh (px per frame)
    similarity: float  # of the estimate's rectangle to the reference
    hidden: bool = False  # taken as occluded this frame: the estimate is the coasting cloud's mean
    # the cloud's own box when `box` was fitted to the foreground mask (None: `box` is that)
    unfitted: np.ndarray | None = None
    # followed by the top part of its box (`upper_share`): `box` is the part the mask shows
    partial: bool = False

    @property
    def cloud_box(self) -> np.ndarray:
        """The particles' estimate, before any fit to the mask."""
        return self.box if self.unfitted is None else self.unfitted


@dataclass(frozen=True)
class ImageView:
    """Where an image lies in the frame the filter's boxes live in (scene px): the image's pixel
    (u, v) is at origin + (u, v) / scale. The default is the identity (boxes in image px)."""

    origin: tuple[float, float] = (0.0, 0.0)
    scale: float = 1.0  # image px per scene px

    def to_image(self, boxes: np.ndarray) -> np.ndarray:
        """Boxes (N, 4) x, y, w, h from scene px to image px."""
        out = boxes * self.scale
        out[:, 0] -= self.origin[0] * self.scale
        out[:, 1] -= self.origin[1] * self.scale
        return out

    def to_scene(self, boxes: np.ndarray) -> np.ndarray:
        """Boxes (N, 4) x, y, w, h from image px to scene px (`to_image`'s inverse)."""
        out = boxes / self.scale
        out[:, 0] += self.origin[0]
        out[:, 1] += self.origin[1]
        return out


def _check_mask_size(foreground: ForegroundMask | None, image: np.ndarray) -> None:
    """Refuse a foreground mask of another size than the image."""
    if foreground is not None and foreground.shape != image.shape[:2]:
        raise ValueError(
            f"the foreground mask is {foreground.shape[1]}x{foreground.shape[0]} px, "
            f"the image {image.shape[1]}x{image.shape[0]}"
        )


class ColourParticleFilter:
    """One target's filter: started on a rectangle of an image, stepped once per frame. Boxes and
    states are in the frame of `view` (scene px when the camera moves; image px by default)."""

    def __init__(
        self,
        image: np.ndarray,
        box: np.ndarray,
        appearance: Appearance,
        config: ParticleFilterConfig,
        rng: np.random.Generator,
        view: ImageView = ImageView(),
    ) -> None:
        box = np.asarray(box, dtype=float)
        if box.shape != (4,) or not np.all(np.isfinite(box)) or min(box[2], box[3]) < MIN_SIDE:
            raise ValueError(f"a start box is x, y, width, height with sides >= {MIN_SIDE} px")
        # the top part's appearance: the same kind, with its own reference
        self.upper = copy.deepcopy(appearance) if config.upper_share > 0 else None
        in_image = view.to_image(box[None])
        appearance.reference(image, in_image[0])
        if self.upper is not None:
            self.upper.reference(image, top_parts(in_image, config.upper_share)[0])
        self.appearance, self.config, self.rng = appearance, config, rng
        self.base_sigma = np.array(config.sigma)
        start = np.concatenate([box, np.zeros(4)])
        self.particles = np.tile(start, (config.particles, 1))  # N copies, velocity 0
        self.estimate = ParticleEstimate(box, np.zeros(4), 1.0)
        self.start_height = ExpectedHeight(float(box[3]), 0.0)  # a flat ground line through it
        self.level: float | None = None  # the best particle's score while the target is seen
        self.upper_level: float | None = None  # the estimate's top part's score while seen whole
        # the estimate's velocity while seen: a plain mean over the first frames, then running
        self.seen_velocity = np.zeros(4)
        self.frames_seen = 0

    def noise(self) -> np.ndarray:
        """This frame's noise std per component (Ext 2 moves it by the last estimate's match)."""
        if self.estimate.hidden:
            return self.config.coast_noise * self.base_sigma
        if not self.config.adaptive_noise:
            return self.base_sigma
        zeta = static_noise_share(
            self.estimate.similarity, self.config.noise_alpha, self.config.noise_beta
        )
        sigma: np.ndarray = self.base_sigma * np.repeat([zeta, 1.0 - zeta], 4)
        return sigma

    def step(
        self,
        image: np.ndarray,
        view: ImageView = ImageView(),
        foreground: ForegroundMask | None = None,
        height: ExpectedHeight | None = None,
    ) -> ParticleEstimate:
        """One frame: `image` bgr8, the motion detector's `foreground` mask of the same image
        for the foreground cue (ignored when the cue is off), and the target's `height` where
        it stands, in the particles' coordinates, for the height prior (ignored when
        `height_spread` is 0)."""
        _check_mask_size(foreground, image)
        if height is None and self.config.height_before_line:
            height = self.start_height
        mask = foreground if self.config.foreground.enabled else None
        particles = self._moved_particles(mask, view, height)
        particles, in_image, raw, hidden, partial = self._scored(image, particles, view, mask)
        weights = self._weights(raw, particles, in_image, mask, height, hidden, partial)
        if self.config.estimate is EstimateRule.MEAN:
            state = weights @ particles
        else:
            state = particles[int(np.argmax(weights))]
        in_image_box = view.to_image(state[None, :4])
        similarity = self._similarity(image, in_image_box, partial)
        if not hidden and not partial:
            self._learn_upper_level(image, in_image_box)
        self._update_velocity(particles, weights, state, hidden)
        box, unfitted = self._estimate_box(state, mask, view, hidden, partial)
        self.estimate = ParticleEstimate(
            box, state[4:].copy(), similarity, hidden, unfitted=unfitted, partial=partial
        )
        if not hidden:
            drawn = resample(weights, self.config.resampling, self.rng, self.config.particles)
            particles = particles[drawn]
        self.particles = particles
        return self.estimate

    def _moved_particles(
        self, mask: ForegroundMask | None, view: ImageView, height: ExpectedHeight | None
    ) -> np.ndarray:
        """The particles propagated one frame; while hidden, rescaled in perspective and joined
        by the probes (when those are on)."""
        # the size moves only where the mask can hold it (colour alone lets it shrink or grow)
        size_noise = self.config.size_noise if mask is not None else 0.0
        particles = propagate(self.particles, self.noise(), self.rng, size_noise)
        if self.estimate.hidden and height is not None and self.config.coast_perspective:
            particles[:, :4] = in_perspective(particles[:, :4], self.particles[:, :4], height)
        if self.estimate.hidden and mask is not None and self.config.probes > 0:
            particles = np.vstack([particles, self._probes(particles, mask, view)])
        return particles

    def _scored(
        self,
        image: np.ndarray,
        particles: np.ndarray,
        view: ImageView,
        mask: ForegroundMask | None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool, bool]:
        """(particles, their boxes in image px, their scores, hidden, partial): the scores of
        the whole boxes, or of their top parts when those follow the target (partial); a hidden
        target's probes dropped again when none found it."""
        in_image = view.to_image(particles[:, :4])
        raw = self.appearance.similarities(image, in_image)
        best = float(self._reappearing(raw, mask, in_image).max())
        upper = self._upper_scores(image, in_image, mask, best)
        partial = upper is not None
        if upper is not None:
            raw, hidden = upper, False
        else:
            hidden = self._hidden(best)
        if hidden and len(particles) > self.config.particles:  # no probe found the target
            kept = self.config.particles
            particles, in_image, raw = particles[:kept], in_image[:kept], raw[:kept]
        return particles, in_image, raw, hidden, partial

    def _weights(
        self,
        raw: np.ndarray,
        particles: np.ndarray,
        in_image: np.ndarray,
        mask: ForegroundMask | None,
        height: ExpectedHeight | None,
        hidden: bool,
        partial: bool,
    ) -> np.ndarray:
        """The particles' normalised weights: the corrected scores times the foreground cue's
        and the height prior's factors."""
        # hidden: the scores say nothing about the target, every particle counts the same
        weights = np.ones(len(raw)) if hidden else corrected_weights(raw, self.config)
        if mask is not None and not hidden and not partial:  # the mask holds only the part seen
            factor = self.config.foreground.weights(mask, in_image)
            if factor is not None:
                weights = weights * factor
        if height is not None and self.config.height_spread > 0 and not hidden:
            weights = weights * height.likelihood(
                particles[:, :4], self.config.height_spread, self.config.aspect_spread
            )
        total = float(weights.sum())
        normalised: np.ndarray = weights / total if total > 0 else np.full(len(raw), 1.0 / len(raw))
        return normalised

    def _update_velocity(
        self, particles: np.ndarray, weights: np.ndarray, state: np.ndarray, hidden: bool
    ) -> None:
        """The velocity seen, updated on a frame the target is seen; on the frame it is first
        hidden, the cloud (`particles`, `state`, in place) set to coast at it."""
        if hidden and not self.estimate.hidden:
            # the last frames, half hidden, slowed the cloud: coast at the velocity seen before,
            # the particles' spread about it narrowed as the noise is
            velocities = particles[:, 4:]
            spread = self.config.coast_noise * (velocities - weights @ velocities)
            particles[:, 4:] = self.seen_velocity + spread
            state[4:] = self.seen_velocity
        elif not hidden:
            # a plain mean over the first frames: a running mean started at 0 would coast a
            # target hidden early at a fraction of its speed
            self.frames_seen += 1
            gain = max(LEVEL_GAIN, 1.0 / self.frames_seen)
            self.seen_velocity += gain * (state[4:] - self.seen_velocity)

    def _estimate_box(
        self,
        state: np.ndarray,
        mask: ForegroundMask | None,
        view: ImageView,
        hidden: bool,
        partial: bool,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """(box, the cloud's own box when `box` was fitted to the mask, else None): the
        state's box, cut to the part in sight when partial, or fitted to the mask by the cue."""
        cue = self.config.foreground
        box, unfitted = state[:4].copy(), None
        if partial and mask is not None:
            unfitted = box
            part = seen_part(mask, view.to_image(box[None])[0], cue.margin, self.config.upper_share)
            box = view.to_scene(part[None])[0]
        elif mask is not None and not hidden and cue.fit > 0:
            unfitted = box
            box = view.to_scene(cue.fitted(mask, view.to_image(box[None])[0])[None])[0]
        return box, unfitted

    def _upper_scores(
        self,
        image: np.ndarray,
        boxes: np.ndarray,
        mask: ForegroundMask | None,
        best: float,
    ) -> np.ndarray | None:
        """On a frame that would take the target as hidden (the best whole box, `best`, below
        `occlusion_ratio` x its level), the scores of the boxes' top parts (`upper_share`) when
        the best of them that the mask holds is not below that share of the top part's own
        level, or, for a target hidden the frame before, not below that level itself (a part
        is less telling than the whole); else None."""
        ratio = self.config.occlusion_ratio
        if self.upper is None or self.level is None or self.upper_level is None:
            return None
        if self.frames_seen < self.config.settle_frames or best >= ratio * self.level:
            return None
        tops = top_parts(boxes, self.config.upper_share)
        scores = self.upper.similarities(image, tops)
        if mask is not None:  # a part in sight moves: the board in front of the rest does not
            scores = self._held_by_mask(scores, mask, tops)
        needed = self.upper_level if self.estimate.hidden else ratio * self.upper_level
        return scores if float(scores.max()) >= needed else None

    def _similarity(self, image: np.ndarray, box: np.ndarray, partial: bool) -> float:
        """The match of the estimate's box (1, 4 in image px): of the whole box; when it is
        followed by its top part, that part's match on the whole box's scale (x the whole's
        level over the part's), which Ext 2's noise and a tracker's "is this a hit" read as they
        read a whole match."""
        if partial and self.upper is not None and self.level and self.upper_level:
            top = self._upper_match(image, box)
            return top * self.level / self.upper_level
        return float(self.appearance.similarities(image, box)[0])

    def _learn_upper_level(self, image: np.ndarray, box: np.ndarray) -> None:
        """On a frame the target is seen whole, the running level of its box's top part."""
        if self.upper is None:
            return
        top, level = self._upper_match(image, box), self.upper_level
        self.upper_level = top if level is None else level + LEVEL_GAIN * (top - level)

    def _upper_match(self, image: np.ndarray, box: np.ndarray) -> float:
        """The top part's match of one box (1, 4 in image px)."""
        assert self.upper is not None, "called only with upper_share > 0"
        return float(self.upper.similarities(image, top_parts(box, self.config.upper_share))[0])

    def _reappearing(
        self, raw: np.ndarray, mask: ForegroundMask | None, boxes: np.ndarray
    ) -> np.ndarray:
        """The scores that may end a hidden spell: with `reappear_in_mask`, only those of boxes
        the foreground mask holds (the cue's `min_best`); the board or wall in front of the
        target, or the street behind it, can match the reference well enough, but never moves."""
        if not (self.config.reappear_in_mask and self.estimate.hidden and mask is not None):
            return raw
        return self._held_by_mask(raw, mask, boxes)

    def _held_by_mask(
        self, scores: np.ndarray, mask: ForegroundMask, boxes: np.ndarray
    ) -> np.ndarray:
        """`scores` where the foreground mask holds the box (the cue's F_beta at least its
        `min_best`), 0 elsewhere."""
        cue = self.config.foreground
        held: np.ndarray = np.where(cue.scores(mask, boxes) >= cue.min_best, scores, 0.0)
        return held

    def _probes(
        self, particles: np.ndarray, foreground: ForegroundMask, view: ImageView
    ) -> np.ndarray:
        """Up to `probes` particles where the foreground mask holds a box of the target's size
        (F_beta of the foreground cue at least its `min_best`) within `probe_reach` heights of
        the coasting cloud's centre: a target that comes out off its dead reckoning is found
        there, where the cloud's own spread would take many frames to reach."""
        guess = particles.mean(axis=0)
        size = guess[2:4]
        count = PROBE_CANDIDATES * self.config.probes
        angle = self.rng.uniform(0.0, 2.0 * np.pi, count)
        radius = self.config.probe_reach * size[1] * np.sqrt(self.rng.random(count))
        directions = np.column_stack([np.cos(angle), np.sin(angle)])
        centres = guess[:2] + size / 2 + radius[:, None] * directions
        boxes = np.column_stack([centres - size / 2, np.tile(size, (count, 1))])
        cue = self.config.foreground
        scores = cue.scores(foreground, view.to_image(boxes))
        best = np.argsort(-scores, kind="stable")[: self.config.probes]
        best = best[scores[best] >= cue.min_best]
        probes = np.zeros((len(best), len(STATE)))
        probes[:, :4] = boxes[best]
        probes[:, 4:] = self.seen_velocity
        return probes

    def _hidden(self, best: float) -> bool:
        """Whether the best score says the target is occluded; else it updates the level."""
        ratio = self.config.occlusion_ratio
        settled = self.frames_seen >= self.config.settle_frames
        if ratio > 0 and settled and self.level is not None and best < ratio * self.level:
            return True
        self.level = best if self.level is None else self.level + LEVEL_GAIN * (best - self.level)
        return False
