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
        per_axis = np.eye(self.order + 1)
        for power in range(1, self.order + 1):
            per_axis += np.diag(
                np.full(self.order + 1 - power, dt**power / math.factorial(power)), power
            )
        return np.kron(per_axis, np.eye(AXES))

    def process_noise(self, dt: float, sigma: float) -> np.ndarray:
        """Q(dt): covariance of the random step of the highest derivative held over dt."""
        gain = np.array(
            [
                dt ** (self.order + 1 - i) / math.factorial(self.order + 1 - i)
                for i in range(self.order + 1)
            ]
        )
        return np.kron(np.outer(gain, gain) * sigma**2, np.eye(AXES))

    def initial_covariance(
        self, position_std: float, velocity_std: float, acceleration_std: float = 0.0
    ) -> np.ndarray:
        """A diagonal covariance for a state initiated from one position measurement."""
        stds = (position_std, velocity_std, acceleration_std)[: self.order + 1]
        return np.diag(np.repeat(np.square(stds), AXES))


CONSTANT_VELOCITY = KinematicModel(order=1)
CONSTANT_ACCELERATION = KinematicModel(order=2)


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
            return means @ model.transition(lead)[:AXES].T
    general = layout if isinstance(layout, StateLayout) else StateLayout.from_names(names)
    return general.positions(means) + lead * general.velocities(means)
