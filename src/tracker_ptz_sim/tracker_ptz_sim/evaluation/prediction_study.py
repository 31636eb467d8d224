"""Seed 001's prediction experiment, reproduced on stated trajectories (no rclpy).

The thesis moved a small ball by hand in two concentric circles in front of a fixed webcam at
20 fps, added an independent integer in [-40, 40] px to CamShift's x and y every frame (simulated
camera vibration), and averaged the one-step prediction error E_i = ||s_i - s_hat_{i|i-1}|| over
the last 80 frames and 100 runs: 44.39 px nominal, 40.92 px robust. The video is not available,
so the hand's path is written down here (`concentric_circles`) and the error is reported
against the noisy position (the thesis's s_i) and against the true one. CamShift's measurement is
either taken as the true centre (the vibration dominates its error) or measured: a purple ball is
rendered on a textured desk at the true centre and `tracker_detect.camshift.camshift` follows it from a
box drawn on it in the first frame (`camshift_centres`). Manoeuvring paths (stops, speed changes,
a figure eight) test where model uncertainty should matter more.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import cv2
import numpy as np
from scipy import stats

from tracker_detect.camshift.camshift import CamShiftTracker
from tracker_detect.detector import CameraFrame
from tracker_filter.filters import FilterFactory
from tracker_filter.models import seed001_nominal_model
from tracker_filter.robust_kalman import LambdaRule, RobustKalmanConfig, seed001_uncertainty
from tracker_msgs_py.geometry import Rect

FPS = 20.0
FRAMES = 200  # 10 s per run
SCORED_FRAMES = 80  # the thesis averages the last 80 frames
VIBRATION_PX = 40  # integer noise in [-40, 40] px per axis per frame
IMAGE_SIZE = (640, 480)  # width, height
CENTRE = np.array([320.0, 240.0])  # of the image
PRIOR_STD = math.sqrt(1e3)  # Pi0 = 1e3 I (the thesis gives no value)
THESIS_PX = {"nominal": 44.39, "robust": 40.92}

Trajectory = Callable[[np.random.Generator], np.ndarray]  # rng -> (FRAMES, 2) true centre, px


def _hand_jitter(rng: np.random.Generator, sigma: float = 1.5) -> np.ndarray:
    """A hand's tremor: Gaussian steps smoothed over 3 frames, px."""
    steps = rng.normal(0.0, sigma, size=(FRAMES + 2, 2))
    return (steps[:-2] + steps[1:-1] + steps[2:]) / 3.0


def _on_path(angle: np.ndarray, radius: np.ndarray) -> np.ndarray:
    points: np.ndarray = CENTRE + np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    return points


def concentric_circles(rng: np.random.Generator) -> np.ndarray:
    """Two concentric circles by hand: radius 160 px at a lap per 2.5 s for the first 4 s, a 1 s
    move inwards, then radius 100 px at a lap per 2 s (the digest's reproduction circle) for the
    rest, which holds the scored last 80 frames. The hand's angular speed wanders +-20 % (one slow
    sinusoid with a random phase), the run starts at a random angle, 1.5 px hand tremor."""
    t = np.arange(FRAMES) / FPS
    phase = rng.uniform(0, 2 * math.pi)
    lap = np.interp(t, [0.0, 4.0, 5.0, t[-1]], [2.5, 2.5, 2.0, 2.0])
    speed = 2 * math.pi / lap * (1.0 + 0.2 * np.sin(2 * math.pi * t / 3.7 + phase))
    angle = rng.uniform(0, 2 * math.pi) + np.cumsum(speed) / FPS
    radius = np.interp(t, [0.0, 4.0, 5.0, t[-1]], [160.0, 160.0, 100.0, 100.0])
    track: np.ndarray = _on_path(angle, radius) + _hand_jitter(rng)
    return track


def stop_and_go(rng: np.random.Generator) -> np.ndarray:
    """The outer circle at one lap per 2.5 s, stopping for 1 s twice (at 3.5 s and at 6.5 s plus
    up to 1 s of random delay)."""
    t = np.arange(FRAMES) / FPS
    moving = np.ones(FRAMES)
    for start in (3.5, 6.5 + rng.uniform(0.0, 1.0)):
        moving[(t >= start) & (t < start + 1.0)] = 0.0
    angle = rng.uniform(0, 2 * math.pi) + np.cumsum(moving) * 2 * math.pi / 2.5 / FPS
    track: np.ndarray = _on_path(angle, np.full(FRAMES, 150.0)) + _hand_jitter(rng)
    return track


def speed_changes(rng: np.random.Generator) -> np.ndarray:
    """The outer circle with the speed jumping every 1.5 s to between 0.4 and 2 laps per 2.5 s."""
    segments = rng.uniform(0.4, 2.0, size=FRAMES // 30 + 1)
    laps = np.repeat(segments, 30)[:FRAMES]
    angle = rng.uniform(0, 2 * math.pi) + np.cumsum(laps) * 2 * math.pi / 2.5 / FPS
    track: np.ndarray = _on_path(angle, np.full(FRAMES, 150.0)) + _hand_jitter(rng)
    return track


def figure_eight(rng: np.random.Generator) -> np.ndarray:
    """A lemniscate 300 x 150 px, one figure per 4 s, from a random point of it."""
    t = np.arange(FRAMES) / FPS
    a = rng.uniform(0, 2 * math.pi) + 2 * math.pi * t / 4.0
    path = np.stack([150.0 * np.sin(a), 75.0 * np.sin(2 * a)], axis=1)
    track: np.ndarray = CENTRE + path + _hand_jitter(rng)
    return track


BALL_RADIUS = 16  # px: a small ball at arm's length from a webcam
BALL_BGR = (150, 40, 125)  # purple


def desk(rng: np.random.Generator) -> np.ndarray:
    """A textured, low-saturation desk and wall behind the ball, (480, 640, 3) BGR."""
    width, height = IMAGE_SIZE
    grey = rng.integers(60, 190, (height // 16, width // 16, 1))
    tint = rng.integers(-10, 11, (height // 16, width // 16, 3))
    small = np.clip(grey + tint, 0, 255).astype(np.uint8)
    background: np.ndarray = cv2.resize(small, IMAGE_SIZE, interpolation=cv2.INTER_LINEAR)
    return background


def render_ball(background: np.ndarray, centre: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The ball at `centre` (sub-pixel, anti-aliased), shaded, with sensor noise."""
    frame = background.copy()
    shift = 4  # cv2 drawing's fractional bits
    at = (round(centre[0] * (1 << shift)), round(centre[1] * (1 << shift)))
    cv2.circle(frame, at, BALL_RADIUS << shift, BALL_BGR, -1, cv2.LINE_AA, shift)
    highlight = (round((centre[0] - 5) * (1 << shift)), round((centre[1] - 5) * (1 << shift)))
    cv2.circle(frame, highlight, 5 << shift, (190, 110, 175), -1, cv2.LINE_AA, shift)
    noise = rng.integers(-5, 6, frame.shape, dtype=np.int16)  # sigma 3.2
    return np.clip(frame + noise, 0, 255).astype(np.uint8)


def camshift_centres(truth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """CamShift's centre of the rendered ball per frame (N, 2): started on the ball's box in the
    first frame as a user would draw it; a miss repeats the last centre (the thesis's loop keeps
    its window)."""
    background = desk(rng)
    tracker = CamShiftTracker()
    side = 2.0 * BALL_RADIUS
    first = CameraFrame(0, render_ball(background, truth[0], rng))
    x0, y0 = (float(v) for v in truth[0])
    reason = tracker.select_region(Rect.from_center(x0, y0, side, side), first)
    if reason is not None:
        raise RuntimeError(f"CamShift cannot start on the ball: {reason}")
    centres = np.empty_like(truth)
    centres[0] = truth[0]
    stamp_ns = round(1e9 / FPS)
    for i in range(1, len(truth)):
        image = render_ball(background, truth[i], rng)
        blobs = tracker.process(CameraFrame(i * stamp_ns, image)).blobs
        centres[i] = (blobs[0].centroid_x, blobs[0].centroid_y) if blobs else centres[i - 1]
    return centres


def true_centres(truth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """CamShift taken as exact: its error is small beside the vibration."""
    return truth


Measure = Callable[[np.ndarray, np.random.Generator], np.ndarray]  # truth, rng -> measured


@dataclass(frozen=True)
class Protocol:
    trajectory: Trajectory
    measure: Measure = true_centres


PROTOCOLS: dict[str, Protocol] = {
    "concentric circles (thesis)": Protocol(concentric_circles),
    "concentric circles, CamShift on a rendered ball": Protocol(
        concentric_circles, camshift_centres
    ),
    "stop and go": Protocol(stop_and_go),
    "speed changes": Protocol(speed_changes),
    "figure eight": Protocol(figure_eight),
}


def predictors(initial_std: float = PRIOR_STD) -> dict[str, FilterFactory]:
    """Seed 001's nominal filter and the robust filter with each lambda_hat rule."""
    model, uncertainty = seed001_nominal_model(), seed001_uncertainty()
    return {
        name: RobustKalmanConfig(model, uncertainty, rule, 0.5, initial_std)
        for name, rule in (
            ("nominal", LambdaRule.NOMINAL),
            ("robust exact", LambdaRule.EXACT),
            ("robust cheap", LambdaRule.CHEAP),
        )
    }


def vibrate(
    truth: np.ndarray, rng: np.random.Generator, amplitude: int = VIBRATION_PX
) -> np.ndarray:
    """The thesis's simulated camera vibration: an independent integer in [-a, a] per axis."""
    return truth + rng.integers(-amplitude, amplitude + 1, size=truth.shape)


def one_step_predictions(factory: FilterFactory, measurements: np.ndarray) -> np.ndarray:
    """s_hat_{i|i-1} for i = 1..N-1 (the first measurement starts the filter), (N-1, 2)."""
    f = factory.new_filter(measurements[0], 0.0)
    out = np.empty((len(measurements) - 1, 2))
    for i, z in enumerate(measurements[1:], start=1):
        f.predict(i / FPS)
        out[i - 1] = f.mean[:2]
        f.update(z)
    return out


@dataclass(frozen=True)
class RunErrors:
    """One run of one predictor: E_i per frame (frames 1..N-1), against noisy and true positions."""

    noisy: np.ndarray
    true: np.ndarray

    def scored(self, frames: int = SCORED_FRAMES) -> tuple[float, float]:
        return float(self.noisy[-frames:].mean()), float(self.true[-frames:].mean())


def run_once(
    protocol: Protocol, factories: Mapping[str, FilterFactory], seed: int
) -> dict[str, RunErrors]:
    rng = np.random.default_rng(seed)
    truth = protocol.trajectory(rng)
    measured = vibrate(protocol.measure(truth, rng), rng)
    out = {}
    for name, factory in factories.items():
        predicted = one_step_predictions(factory, measured)
        out[name] = RunErrors(
            np.linalg.norm(measured[1:] - predicted, axis=1),
            np.linalg.norm(truth[1:] - predicted, axis=1),
        )
    return out


@dataclass(frozen=True)
class PairedComparison:
    """robust minus nominal, per run (px): negative = robust predicts better."""

    mean: float
    std: float
    robust_better: int  # runs
    runs: int
    p_value: float  # Wilcoxon signed-rank, two-sided

    @classmethod
    def of(cls, robust: np.ndarray, nominal: np.ndarray) -> PairedComparison:
        diff = np.asarray(robust) - np.asarray(nominal)
        p = float(stats.wilcoxon(diff).pvalue) if np.any(diff != 0) else 1.0
        return cls(float(diff.mean()), float(diff.std(ddof=1)), int((diff < 0).sum()), len(diff), p)


@dataclass
class ProtocolResult:
    """Per predictor: the per-run scored means (noisy, true), the per-frame mean error curves and
    the first run's own curve (the thesis's live plot)."""

    protocol: str
    scored_noisy: dict[str, np.ndarray]
    scored_true: dict[str, np.ndarray]
    curves_noisy: dict[str, np.ndarray]
    first_run_noisy: dict[str, np.ndarray]

    def comparison(self, robust: str, against: str = "true") -> PairedComparison:
        scored = self.scored_true if against == "true" else self.scored_noisy
        return PairedComparison.of(scored[robust], scored["nominal"])


def run_protocol(
    name: str,
    protocol: Protocol,
    runs: int = 100,
    seed: int = 0,
    factories: Mapping[str, FilterFactory] | None = None,
    progress: Callable[[int], None] | None = None,
) -> ProtocolResult:
    """`runs` runs with seeds seed, seed + 1, ... (the same noise for every predictor)."""
    factories = factories or predictors()
    noisy: dict[str, list[float]] = {n: [] for n in factories}
    true: dict[str, list[float]] = {n: [] for n in factories}
    curves: dict[str, np.ndarray] = {n: np.zeros(FRAMES - 1) for n in factories}
    first: dict[str, np.ndarray] = {}
    for k in range(runs):
        for predictor, errors in run_once(protocol, factories, seed + k).items():
            scored_noisy, scored_true = errors.scored()
            noisy[predictor].append(scored_noisy)
            true[predictor].append(scored_true)
            curves[predictor] += errors.noisy / runs
            first.setdefault(predictor, errors.noisy)
        if progress is not None:
            progress(k + 1)
    return ProtocolResult(
        name,
        {n: np.array(v) for n, v in noisy.items()},
        {n: np.array(v) for n, v in true.items()},
        curves,
        first,
    )
