"""Single-target filters behind one small interface (no rclpy).

`StateFilter` is what every filter offers, whatever it is inside: the alpha-beta and Kalman filters
here, and later the robust Kalman filter (seed 001) and particle filters (seeds 002/003):

- ``predict(t)`` moves the estimate to time t (seconds from header stamps; any dt >= 0). It commits
  the previous step: predicting again without an update is a missed measurement.
- ``update(z)`` corrects with a position measurement (2,), or with None for a missed one, which is
  a pure prediction (the seed 000 prototype also shrank the covariance on misses; not copied).
- ``mean``/``covariance`` in ``state_layout`` order, ``measurement_prediction()`` for gating, and
  ``predicted_position(lead)`` for the pan-tilt controller.

`FilterConfig` describes one of the four filters of seed 000 and makes either one filter
(`new_filter`) or a vectorised bank of them for the multi-target tracker (`new_bank`).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Protocol, runtime_checkable

import numpy as np
from filterpy.gh import GHFilter, GHKFilter
from filterpy.kalman import KalmanFilter as FilterpyKalmanFilter

from tracker_filter.banks import FilterBank, LinearGaussianBank, ObjectBank
from tracker_filter.gains import GainRule, GhGains, gain_schedule, resolve_gains
from tracker_filter.linear_gaussian import fixed_gain, joseph_update
from tracker_filter.models import (
    AXES,
    CONSTANT_ACCELERATION,
    CONSTANT_VELOCITY,
    KinematicModel,
    LinearModel,
)


@runtime_checkable
class StateFilter(Protocol):
    """The interface every single-target filter offers (see the module docstring)."""

    @property
    def state_layout(self) -> tuple[str, ...]: ...

    @property
    def time(self) -> float: ...

    @property
    def mean(self) -> np.ndarray: ...

    @property
    def covariance(self) -> np.ndarray: ...

    def predict(self, t: float) -> None: ...

    def update(self, z: np.ndarray | None) -> None: ...

    def measurement_prediction(self) -> tuple[np.ndarray, np.ndarray]: ...

    def predicted_position(self, lead: float) -> np.ndarray: ...


class FilterFactory(Protocol):
    """Makes filters for new tracks: one at a time, or a bank the tracker steps all at once."""

    @property
    def state_layout(self) -> tuple[str, ...]: ...

    def new_filter(self, z: np.ndarray, t: float) -> StateFilter: ...

    def new_bank(self) -> FilterBank: ...


def check_measurement(z: np.ndarray | None) -> np.ndarray | None:
    """z as a float (2,) array, None kept; raises ValueError for a wrong shape or NaN/inf."""
    if z is None:
        return None
    z = np.asarray(z, dtype=float).reshape(-1)
    if z.shape != (AXES,) or not np.all(np.isfinite(z)):
        raise ValueError(f"a measurement must be 2 finite numbers, got {z.tolist()}")
    return z


class KinematicFilter(ABC):
    """Shared part of the filters on a `KinematicModel`: time checks, gating, lead prediction."""

    def __init__(
        self,
        model: KinematicModel | LinearModel,
        measurement_noise: float,
        t0: float,
        measurement_covariance: np.ndarray | None = None,
    ) -> None:
        if not math.isfinite(t0):
            raise ValueError(f"start time must be finite, got {t0}")
        self.model = model
        self.measurement_covariance = (
            np.eye(AXES) * measurement_noise**2
            if measurement_covariance is None
            else np.asarray(measurement_covariance, dtype=float)
        )
        self._time = float(t0)

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.model.state_layout

    @property
    def time(self) -> float:
        return self._time

    @property
    @abstractmethod
    def mean(self) -> np.ndarray:
        """State mean, in `state_layout` order."""

    @property
    @abstractmethod
    def covariance(self) -> np.ndarray:
        """State covariance."""

    def _interval_to(self, t: float) -> float:
        """dt from the filter's time to t; raises ValueError (state untouched) for NaN or the past."""
        if not math.isfinite(t) or t < self._time:
            raise ValueError(f"cannot predict from t = {self._time} s back to t = {t} s")
        return t - self._time

    def measurement_prediction(self) -> tuple[np.ndarray, np.ndarray]:
        """Predicted measurement H x and its covariance S = H P H^T + R."""
        return self.mean[:AXES], self.covariance[:AXES, :AXES] + self.measurement_covariance

    def predicted_position(self, lead: float) -> np.ndarray:
        """Position the current estimate reaches after `lead` seconds of its own motion."""
        position: np.ndarray = self.model.transition(lead)[:AXES] @ self.mean
        return position


class KalmanFilter(KinematicFilter):
    """Kalman filter on filterpy's KalmanFilter, for a kinematic model (constant velocity or
    acceleration) or an explicit `LinearModel`:

        predict  x = F x,  P = F P F^T + Q(dt)
        update   K = P H^T (H P H^T + R)^-1,  x += K (z - H x),  P = (I - K H) P
    """

    def __init__(
        self,
        model: KinematicModel | LinearModel,
        x0: np.ndarray,
        P0: np.ndarray,
        t0: float,
        process_noise: float,
        measurement_noise: float,
        measurement_covariance: np.ndarray | None = None,
    ) -> None:
        super().__init__(model, measurement_noise, t0, measurement_covariance)
        self.process_noise = process_noise
        self._kf = FilterpyKalmanFilter(dim_x=model.dim, dim_z=AXES)
        self._kf.x = np.array(x0, dtype=float)
        self._kf.P = np.array(P0, dtype=float)
        self._kf.R = self.measurement_covariance.copy()
        self._kf.H = model.measurement_matrix

    @property
    def mean(self) -> np.ndarray:
        mean: np.ndarray = self._kf.x.copy()
        return mean

    @property
    def covariance(self) -> np.ndarray:
        covariance: np.ndarray = self._kf.P.copy()
        return covariance

    def predict(self, t: float) -> None:
        dt = self._interval_to(t)
        self._kf.predict(
            F=self.model.transition(dt), Q=self.model.process_noise(dt, self.process_noise)
        )
        self._time = float(t)

    def update(self, z: np.ndarray | None) -> None:
        # filterpy's update(None) leaves x and P at the prediction: a miss is a pure prediction.
        # (The seed 000 prototype also applied P = (I - KH) P on misses; deliberately not copied.)
        self._kf.update(check_measurement(z))


class AlphaBetaFilter(KinematicFilter):
    """Alpha-beta (gains.gamma None) or alpha-beta-gamma filter on filterpy's g-h(-k) filters.

    filterpy's update() predicts and corrects in one call from the last committed state, so this
    class keeps the prediction aside until the next update (or commits it as a coast on a miss).
    Besides the mean it carries the error covariance of the fixed-gain estimator under the model's
    white-noise process (Joseph form with the gains actually used), so alpha-beta tracks can be
    gated like Kalman tracks.
    """

    def __init__(
        self,
        gains: GhGains,
        x0: np.ndarray,
        P0: np.ndarray,
        t0: float,
        process_noise: float,
        measurement_noise: float,
        startup: bool = True,
    ) -> None:
        model = CONSTANT_VELOCITY if gains.order == 1 else CONSTANT_ACCELERATION
        super().__init__(model, measurement_noise, t0)
        self.gains = gains
        self.process_noise = process_noise
        self.startup = startup
        self._mean = np.array(x0, dtype=float)
        self._covariance = np.array(P0, dtype=float)
        blocks = np.split(self._mean.copy(), gains.order + 1)
        if gains.order == 1:
            self._gh = GHFilter(x=blocks[0], dx=blocks[1], dt=1.0, g=gains.alpha, h=gains.beta)
        else:
            self._gh = GHKFilter(
                x=blocks[0],
                dx=blocks[1],
                ddx=blocks[2],
                dt=1.0,
                g=gains.alpha,
                h=gains.beta,
                k=gains.gamma,
            )
        self._dt = 0.0  # interval of the prediction not yet handed to the g-h filter
        self._measurements = 1  # the initiating measurement counts as the first (n = 0)

    @property
    def mean(self) -> np.ndarray:
        return self._mean.copy()

    @property
    def covariance(self) -> np.ndarray:
        return self._covariance.copy()

    def _commit(self) -> None:
        """Hand the current estimate to the g-h filter (after a coast, before the next step)."""
        blocks = np.split(self._mean.copy(), self.gains.order + 1)
        self._gh.x, self._gh.dx = blocks[0], blocks[1]
        if self.gains.order == 2:
            self._gh.ddx = blocks[2]
        self._dt = 0.0

    def predict(self, t: float) -> None:
        dt = self._interval_to(t)
        if dt == 0.0:
            return
        if self._dt > 0.0:
            self._commit()  # the previous interval ended without a measurement: it was a coast
        transition = self.model.transition(dt)
        self._mean = transition @ self._mean
        self._covariance = transition @ self._covariance @ transition.T + self.model.process_noise(
            dt, self.process_noise
        )
        self._dt = dt
        self._time = float(t)

    def update(self, z: np.ndarray | None) -> None:
        z = check_measurement(z)
        if z is None:
            self._commit()
            return
        g, h, k = (float(v) for v in gain_schedule(self.gains, self._measurements, self.startup))
        dt = self._dt
        if dt > 0.0:
            self._gh.dt = dt
            if self.gains.order == 1:
                self._gh.update(z, g=g, h=h)
            else:
                self._gh.update(z, g=g, h=h, k=k)
            self._mean = np.concatenate(
                [self._gh.x, self._gh.dx] + ([self._gh.ddx] if self.gains.order == 2 else [])
            )
        else:
            self._mean[:AXES] += g * (z - self._mean[:AXES])  # no interval: position only
            self._commit()
        gain = fixed_gain(np.asarray(g), np.asarray(h), np.asarray(k), dt, self.gains.order)
        self._covariance = joseph_update(self._covariance, gain, self.measurement_covariance)
        self._dt = 0.0
        self._measurements += 1


class FilterKind(StrEnum):
    ALPHA_BETA = "alpha_beta"
    ALPHA_BETA_GAMMA = "alpha_beta_gamma"
    KALMAN_CV = "kalman_cv"
    KALMAN_CA = "kalman_ca"

    @property
    def model(self) -> KinematicModel:
        return (
            CONSTANT_VELOCITY
            if self in (FilterKind.ALPHA_BETA, FilterKind.KALMAN_CV)
            else CONSTANT_ACCELERATION
        )

    @property
    def fixed_gain(self) -> bool:
        return self in (FilterKind.ALPHA_BETA, FilterKind.ALPHA_BETA_GAMMA)


def _positive(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} must be a positive number, got {value}")


@dataclass(frozen=True, eq=False)
class FilterConfig:
    """One of seed 000's filters with its noise model; a `FilterFactory`.

    process_noise is the standard deviation of the white acceleration (px/s^2, constant velocity)
    or jerk (px/s^3, constant acceleration); the alpha-beta filters use it only for their
    covariance. A new track starts at the measurement with zero velocity (and acceleration) and
    covariance diag(measurement_noise^2, initial_velocity_std^2, initial_acceleration_std^2) per
    axis, unless `initial_covariance` gives the matrix (seed 000: P0 = Q).
    """

    kind: FilterKind = FilterKind.KALMAN_CV
    measurement_noise: float = 2.0
    process_noise: float = 100.0
    initial_velocity_std: float = 100.0
    initial_acceleration_std: float = 100.0
    gains: GhGains | None = None
    startup: bool = True
    initial_covariance: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", FilterKind(self.kind))
        for name in (
            "measurement_noise",
            "process_noise",
            "initial_velocity_std",
            "initial_acceleration_std",
        ):
            _positive(name, getattr(self, name))
        if self.kind.fixed_gain:
            order = self.kind.model.order
            if self.gains is None:
                object.__setattr__(self, "gains", resolve_gains(0.6, GainRule.KALATA, order))
            elif self.gains.order != order:
                raise ValueError(
                    f"{self.kind.value} needs {'alpha, beta' if order == 1 else 'alpha, beta, gamma'} gains"
                )
        if self.initial_covariance is not None:
            matrix = np.array(self.initial_covariance, dtype=float)
            n = self.kind.model.dim
            symmetric = matrix.shape == (n, n) and np.allclose(matrix, matrix.T)
            if not symmetric or np.linalg.eigvalsh(matrix).min() < -1e-9 * np.abs(matrix).max():
                raise ValueError(
                    f"initial_covariance must be a symmetric positive semi-definite {n}x{n} matrix"
                )
            object.__setattr__(self, "initial_covariance", matrix)

    @property
    def model(self) -> KinematicModel:
        return self.kind.model

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.model.state_layout

    def initial_state_covariance(self) -> np.ndarray:
        if self.initial_covariance is not None:
            return self.initial_covariance.copy()
        return self.model.initial_covariance(
            self.measurement_noise, self.initial_velocity_std, self.initial_acceleration_std
        )

    def initial_state(self, z: np.ndarray) -> np.ndarray:
        return np.concatenate([check_measurement(z), np.zeros(self.model.dim - AXES)])

    def new_filter(self, z: np.ndarray, t: float) -> StateFilter:
        x0, P0 = self.initial_state(z), self.initial_state_covariance()
        if self.kind.fixed_gain:
            assert self.gains is not None, "__post_init__ gives fixed-gain kinds their gains"
            return AlphaBetaFilter(
                self.gains, x0, P0, t, self.process_noise, self.measurement_noise, self.startup
            )
        return KalmanFilter(self.model, x0, P0, t, self.process_noise, self.measurement_noise)

    def new_bank(self) -> FilterBank:
        return LinearGaussianBank(
            self.model,
            self.measurement_noise,
            self.process_noise,
            self.initial_state_covariance(),
            gains=self.gains if self.kind.fixed_gain else None,
            startup=self.startup,
        )


@dataclass(frozen=True, eq=False)
class LinearModelFilterConfig:
    """Kalman filters on an explicit `LinearModel` (F, G, Q, R); a `FilterFactory`.

    A new track starts at the measurement with the rest of the state zero and covariance
    blockdiag(R, initial_std^2 I) (seed 001 gives no P0).
    """

    model: LinearModel
    initial_std: float = 100.0

    def __post_init__(self) -> None:
        _positive("initial_std", self.initial_std)

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.model.state_layout

    def initial_state_covariance(self) -> np.ndarray:
        covariance = np.eye(self.model.dim) * self.initial_std**2
        covariance[:AXES, :AXES] = self.model.measurement_covariance
        return covariance

    def new_filter(self, z: np.ndarray, t: float) -> StateFilter:
        x0 = np.concatenate([check_measurement(z), np.zeros(self.model.dim - AXES)])
        R = self.model.measurement_covariance
        return KalmanFilter(self.model, x0, self.initial_state_covariance(), t, 1.0, 1.0, R)

    def new_bank(self) -> FilterBank:
        return LinearGaussianBank(
            self.model,
            1.0,
            1.0,
            self.initial_state_covariance(),
            measurement_covariance=self.model.measurement_covariance,
        )


class PerTrackFactory:
    """A FilterFactory that keeps one filter object per track (an ObjectBank) instead of the
    vectorised bank: the way in for filters without a vectorised form (robust Kalman, particle
    filters), and the reference the vectorised bank is measured against."""

    def __init__(self, factory: FilterFactory) -> None:
        self.factory = factory
        self.state_layout = factory.state_layout

    def new_filter(self, z: np.ndarray, t: float) -> StateFilter:
        return self.factory.new_filter(z, t)

    def new_bank(self) -> FilterBank:
        return ObjectBank(self.factory.new_filter, self.state_layout)
