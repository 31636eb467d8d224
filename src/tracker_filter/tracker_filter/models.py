"""Kinematic motion models shared by every filter (no rclpy).

States are laid out by derivative blocks, both axes per block: ``x y vx vy`` (constant velocity)
or ``x y vx vy ax ay`` (constant acceleration), in scene pixels and seconds. The measurement is the
position ``(x, y)``, i.e. the first two state elements.

Process noise is the piecewise-constant white-noise model: the highest derivative receives an
independent random step per axis with standard deviation ``sigma`` (px/s^2 for constant velocity,
px/s^3 for constant acceleration) held over the interval ``dt``. For constant velocity this is the
seed 000 matrix (digest section 3, with the erratum "T should read T^2" applied):

    Q = sigma^2 [[dt^4/4 I, dt^3/2 I], [dt^3/2 I, dt^2 I]]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tracker_filter.layout import StateLayout

AXES = 2  # the scene is a plane: x and y


@dataclass(frozen=True)
class KinematicModel:
    """A polynomial motion model of the given order (1: constant velocity, 2: acceleration)."""

    order: int

    def __post_init__(self) -> None:
        if self.order not in (1, 2):
            raise ValueError(f"model order must be 1 or 2, got {self.order}")

    @property
    def dim(self) -> int:
        """Length of the state vector."""
        return AXES * (self.order + 1)

    @property
    def state_layout(self) -> tuple[str, ...]:
        names = ("x y", "vx vy", "ax ay")[: self.order + 1]
        return tuple(" ".join(names).split())

    @property
    def measurement_matrix(self) -> np.ndarray:
        """H: picks the position out of the state."""
        return np.eye(AXES, self.dim)

    def transition(self, dt: float) -> np.ndarray:
        """F(dt): the state transition over dt seconds."""
        blocks = self.order + 1
        per_axis = np.eye(blocks)
        for i in range(blocks):
            for j in range(i + 1, blocks):
                per_axis[i, j] = dt ** (j - i) / math.factorial(j - i)
        return _each_axis(per_axis)

    def process_noise(self, dt: float, sigma: float) -> np.ndarray:
        """Q(dt): covariance of the random step of the highest derivative held over dt."""
        gain = np.array(
            [
                dt ** (self.order + 1 - i) / math.factorial(self.order + 1 - i)
                for i in range(self.order + 1)
            ]
        )
        return _each_axis(np.outer(gain, gain) * sigma**2)

    def initial_covariance(
        self, position_std: float, velocity_std: float, acceleration_std: float = 0.0
    ) -> np.ndarray:
        """A diagonal covariance for a state initiated from one position measurement."""
        stds = (position_std, velocity_std, acceleration_std)[: self.order + 1]
        return np.diag(np.repeat(np.square(stds), AXES))


def _each_axis(per_axis: np.ndarray) -> np.ndarray:
    """The matrix over both axes' interleaved blocks (x y, vx vy, ...) of a per-axis one: its
    Kronecker product with I2, written out (np.kron costs ~15 us, and this runs every step)."""
    blocks = len(per_axis)
    out = np.zeros((AXES * blocks, AXES * blocks))
    for axis in range(AXES):
        out[axis::AXES, axis::AXES] = per_axis
    return out


CONSTANT_VELOCITY = KinematicModel(order=1)
CONSTANT_ACCELERATION = KinematicModel(order=2)


@dataclass(frozen=True, eq=False)
class LinearModel:
    """A discrete-time linear-Gaussian model given by its matrices, one step per frame:

        x_{k+1} = F x_k + G w_k,  w_k ~ N(0, Q);   z_k = H x_k + v_k,  v_k ~ N(0, R),  H = [I 0]

    (seed 001 section 2 writes its filters this way). The position must be the first two state
    elements. `transition`/`process_noise` ignore the interval: every step is one frame.
    """

    transition_matrix: np.ndarray  # F (n, n)
    noise_gain: np.ndarray  # G (n, m)
    process_covariance: np.ndarray  # Q (m, m)
    measurement_covariance: np.ndarray  # R (2, 2)
    state_layout: tuple[str, ...]

    def __post_init__(self) -> None:
        names = tuple(self.state_layout)
        n = len(names)
        if names[:AXES] != ("x", "y"):
            raise ValueError("a linear model's state must start with x y (H = [I 0])")
        f = np.asarray(self.transition_matrix, dtype=float)
        g = np.asarray(self.noise_gain, dtype=float)
        q = np.asarray(self.process_covariance, dtype=float)
        r = np.asarray(self.measurement_covariance, dtype=float)
        if f.shape != (n, n):
            raise ValueError(f"F must be {n}x{n} for the state {' '.join(names)}, got {f.shape}")
        if g.ndim != 2 or g.shape[0] != n:
            raise ValueError(f"G must have {n} rows, got {g.shape}")
        m = g.shape[1]
        if q.shape != (m, m) or r.shape != (AXES, AXES):
            raise ValueError(f"Q must be {m}x{m} and R 2x2, got {q.shape} and {r.shape}")
        for name, matrix in (("Q", q), ("R", r)):
            tolerance = -1e-9 * max(float(np.abs(matrix).max()), 1.0)  # round-off of a PSD matrix
            if not np.allclose(matrix, matrix.T) or np.linalg.eigvalsh(matrix).min() < tolerance:
                raise ValueError(f"{name} must be symmetric positive semi-definite")
        if np.linalg.eigvalsh(r).min() <= 0:
            raise ValueError("R must be positive definite")
        for name, value in (
            ("transition_matrix", f),
            ("noise_gain", g),
            ("process_covariance", q),
            ("measurement_covariance", r),
            ("state_layout", names),
        ):
            object.__setattr__(self, name, value)

    @property
    def dim(self) -> int:
        return len(self.state_layout)

    @property
    def measurement_matrix(self) -> np.ndarray:
        return np.eye(AXES, self.dim)

    def transition(self, dt: float) -> np.ndarray:
        return self.transition_matrix

    def process_noise(self, dt: float, sigma: float = 1.0) -> np.ndarray:
        """G Q G^T (sigma is not used: Q is given)."""
        noise: np.ndarray = self.noise_gain @ self.process_covariance @ self.noise_gain.T
        return noise


def seed001_nominal_model(frame_interval: float = 1.0 / 20.0) -> LinearModel:
    """Seed 001's nominal constant-acceleration filter (section 2): T = 1/20 s, G = I6,
    Q = diag(3, 3, 1, 1, 0.25, 0.25), R = diag(3, 3)."""
    return LinearModel(
        CONSTANT_ACCELERATION.transition(frame_interval),
        np.eye(6),
        np.diag([3.0, 3.0, 1.0, 1.0, 0.25, 0.25]),
        np.diag([3.0, 3.0]),
        CONSTANT_ACCELERATION.state_layout,
    )


def model_for_layout(state_layout: tuple[str, ...]) -> KinematicModel:
    """The model whose state layout is `state_layout`."""
    for model in (CONSTANT_VELOCITY, CONSTANT_ACCELERATION):
        if model.state_layout == tuple(state_layout):
            return model
    raise ValueError(f"no kinematic model has the state layout {' '.join(state_layout)!r}")


def extrapolate_positions(
    means: np.ndarray, layout: StateLayout | tuple[str, ...], lead: float
) -> np.ndarray:
    """Positions (N, 2) that states `means` (N, n) reach after `lead` seconds of their own motion:
    the kinematic model's transition for its layouts, else position + lead x velocity."""
    means = np.atleast_2d(means)
    names = layout.names if isinstance(layout, StateLayout) else tuple(layout)
    for model in (CONSTANT_VELOCITY, CONSTANT_ACCELERATION):
        if model.state_layout == names:
            positions: np.ndarray = means @ model.transition(lead)[:AXES].T
            return positions
    general = layout if isinstance(layout, StateLayout) else StateLayout.from_names(names)
    return general.positions(means) + lead * general.velocities(means)
