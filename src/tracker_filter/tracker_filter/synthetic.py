"""Synthetic trajectories and multi-target scenes with ground truth, for tests and benchmarks
(no rclpy). Positions are scene pixels, times seconds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tracker_filter.observation import Detections


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Ground truth sampled at `times` (K,): positions and velocities (K, 2)."""

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    def measurements(self, sigma: float, rng: np.random.Generator) -> np.ndarray:
        """Positions with white Gaussian noise of std `sigma` px per axis."""
        return self.positions + rng.normal(scale=sigma, size=self.positions.shape)


def piecewise_constant_velocity(
    start: tuple[float, float], segments: list[tuple[float, tuple[float, float]]], dt: float
) -> Trajectory:
    """Straight segments [(duration s, (vx, vy) px/s)] joined by abrupt turns; (0, 0) is a stop."""
    velocities = np.concatenate(
        [np.tile(np.asarray(v, dtype=float), (round(duration / dt), 1)) for duration, v in segments]
    )
    positions = np.asarray(start, dtype=float) + np.concatenate(
        [np.zeros((1, 2)), np.cumsum(velocities[:-1] * dt, axis=0)]
    )
    return Trajectory(np.arange(len(velocities)) * dt, positions, velocities)


def seed_case1(dt: float = 0.12, speed: float = 60.0, leg: float = 3.0) -> Trajectory:
    """A broken line with 8 abrupt turns (seed 000, section 6.2, Case 1): 9 legs of `leg` seconds."""
    headings = np.deg2rad([0, 60, -30, 90, 0, -90, 45, -45, 180])
    segments = [(leg, (speed * np.cos(h), speed * np.sin(h))) for h in headings]
    return piecewise_constant_velocity((100.0, 300.0), segments, dt)


def circle(
    centre: tuple[float, float], radius: float, period: float, duration: float, dt: float
) -> Trajectory:
    """Uniform circular motion (a smooth curve)."""
    times = np.arange(round(duration / dt)) * dt
    phase = 2.0 * np.pi * times / period
    positions = np.asarray(centre) + radius * np.column_stack([np.cos(phase), np.sin(phase)])
    velocities = radius * 2.0 * np.pi / period * np.column_stack([-np.sin(phase), np.cos(phase)])
    return Trajectory(times, positions, velocities)


@dataclass(frozen=True, eq=False)
class Frame:
    """One frame of a multi-target scene: true ids and positions, and the detections made."""

    time: float
    truth_ids: np.ndarray
    truth_positions: np.ndarray
    detections: Detections


def bouncing_scene(
    rng: np.random.Generator,
    targets: int,
    clutter: int,
    frames: int,
    dt: float = 0.12,
    size: tuple[float, float] = (1920.0, 1080.0),
    speed: tuple[float, float] = (20.0, 80.0),
    noise: float = 1.5,
    blob_size: float = 20.0,
    start_region: tuple[float, float] = (0.05, 0.95),
) -> list[Frame]:
    """Targets on straight paths reflected at the scene borders, each detected every frame with
    noise, plus `clutter` false detections per frame uniformly over the scene. Targets start
    uniformly inside `start_region` (fractions of the scene size)."""
    bounds = np.asarray(size, dtype=float)
    positions = rng.uniform(*start_region, size=(targets, 2)) * bounds
    headings = rng.uniform(0.0, 2.0 * np.pi, size=targets)
    velocities = rng.uniform(*speed, size=targets)[:, None] * np.column_stack(
        [np.cos(headings), np.sin(headings)]
    )
    scene = []
    for k in range(frames):
        measured = positions + rng.normal(scale=noise, size=positions.shape)
        false = rng.uniform(0.0, 1.0, size=(clutter, 2)) * bounds
        detections = Detections.from_positions(np.concatenate([measured, false]), size=blob_size)
        scene.append(Frame(k * dt, np.arange(1, targets + 1), positions.copy(), detections))
        positions = positions + velocities * dt
        outside = (positions < 0.0) | (positions > bounds)
        velocities = np.where(outside, -velocities, velocities)
        positions = np.clip(positions, 0.0, bounds)
    return scene
