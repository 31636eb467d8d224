"""Seed 001's prediction experiment, reproduced on stated trajectories (no rclpy).

The thesis moved a small ball by hand in two concentric circles in front of a fixed webcam at
20 fps, added an independent integer in [-40, 40] px to CamShift's x and y every frame (simulated
camera vibration), and averaged the one-step prediction error E_i = ||s_i - s_hat_{i|i-1}|| over
the last 80 frames and 100 runs: 44.39 px nominal, 40.92 px robust. The video is not available,
so the hand's path is written down here (`concentric_circles`), CamShift's measurement is taken
as the true centre (the vibration dominates its error), and the error is reported against the
noisy position (the thesis's s_i) and against the true one. Manoeuvring paths (stops, speed
changes, a figure eight) test where model uncertainty should matter more.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy import stats

from tracker_filter.filters import FilterFactory
from tracker_filter.models import seed001_nominal_model
from tracker_filter.robust_kalman import LambdaRule, RobustKalmanConfig, seed001_uncertainty

FPS = 20.0
FRAMES = 200  # 10 s per run
SCORED_FRAMES = 80  # the thesis averages the last 80 frames
VIBRATION_PX = 40  # integer noise in [-40, 40] px per axis per frame
CENTRE = np.array([320.0, 240.0])  # a 640 x 480 image
PRIOR_STD = math.sqrt(1e3)  # Pi0 = 1e3 I (the thesis gives no value)
THESIS_PX = {"nominal": 44.39, "robust": 40.92}

Trajectory = Callable[[np.random.Generator], np.ndarray]  # rng -> (FRAMES, 2) true centre, px


def _hand_jitter(rng: np.random.Generator, sigma: float = 1.5) -> np.ndarray:
    """A hand's tremor: Gaussian steps smoothed over 3 frames, px."""
    steps = rng.normal(0.0, sigma, size=(FRAMES + 2, 2))
    return (steps[:-2] + steps[1:-1] + steps[2:]) / 3.0


def _on_path(angle: np.ndarray, radius: np.ndarray) -> np.ndarray:
    return CENTRE + np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


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
    return _on_path(angle, radius) + _hand_jitter(rng)


def stop_and_go(rng: np.random.Generator) -> np.ndarray:
    """The outer circle at one lap per 2.5 s, stopping for 1 s twice (at 3.5 s and at 6.5 s plus
    up to 1 s of random delay)."""
    t = np.arange(FRAMES) / FPS
    moving = np.ones(FRAMES)
    for start in (3.5, 6.5 + rng.uniform(0.0, 1.0)):
        moving[(t >= start) & (t < start + 1.0)] = 0.0
    angle = rng.uniform(0, 2 * math.pi) + np.cumsum(moving) * 2 * math.pi / 2.5 / FPS
    return _on_path(angle, np.full(FRAMES, 150.0)) + _hand_jitter(rng)


def speed_changes(rng: np.random.Generator) -> np.ndarray:
    """The outer circle with the speed jumping every 1.5 s to between 0.4 and 2 laps per 2.5 s."""
    segments = rng.uniform(0.4, 2.0, size=FRAMES // 30 + 1)
    laps = np.repeat(segments, 30)[:FRAMES]
    angle = rng.uniform(0, 2 * math.pi) + np.cumsum(laps) * 2 * math.pi / 2.5 / FPS
    return _on_path(angle, np.full(FRAMES, 150.0)) + _hand_jitter(rng)


def figure_eight(rng: np.random.Generator) -> np.ndarray:
    """A lemniscate 300 x 150 px, one figure per 4 s, from a random point of it."""
    t = np.arange(FRAMES) / FPS
    a = rng.uniform(0, 2 * math.pi) + 2 * math.pi * t / 4.0
    path = np.stack([150.0 * np.sin(a), 75.0 * np.sin(2 * a)], axis=1)
    return CENTRE + path + _hand_jitter(rng)


PROTOCOLS: dict[str, Trajectory] = {
    "concentric circles (thesis)": concentric_circles,
    "stop and go": stop_and_go,
    "speed changes": speed_changes,
    "figure eight": figure_eight,
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
    trajectory: Trajectory, factories: Mapping[str, FilterFactory], seed: int
) -> dict[str, RunErrors]:
    rng = np.random.default_rng(seed)
    truth = trajectory(rng)
    measured = vibrate(truth, rng)
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
    """Per predictor: the per-run scored means (noisy, true) and the per-frame mean error curves."""

    protocol: str
    scored_noisy: dict[str, np.ndarray]
    scored_true: dict[str, np.ndarray]
    curves_noisy: dict[str, np.ndarray]

    def comparison(self, robust: str, against: str = "true") -> PairedComparison:
        scored = self.scored_true if against == "true" else self.scored_noisy
        return PairedComparison.of(scored[robust], scored["nominal"])


def run_protocol(
    name: str,
    trajectory: Trajectory,
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
    for k in range(runs):
        for predictor, errors in run_once(trajectory, factories, seed + k).items():
            scored_noisy, scored_true = errors.scored()
            noisy[predictor].append(scored_noisy)
            true[predictor].append(scored_true)
            curves[predictor] += errors.noisy / runs
        if progress is not None:
            progress(k + 1)
    return ProtocolResult(
        name,
        {n: np.array(v) for n, v in noisy.items()},
        {n: np.array(v) for n, v in true.items()},
        curves,
    )
