"""Filter banks: the filters of all tracks, stepped together (no rclpy).

The multi-target tracker never loops over tracks in Python: it asks its bank to predict every
track to the frame time, for the predicted measurements and their covariances (gating), and to
correct the rows that received a measurement. Rows are tracks in the tracker's order.

- `LinearGaussianBank` does this with stacked NumPy arrays for the Kalman and alpha-beta(-gamma)
  filters. It performs exactly the steps of `filters.KalmanFilter` / `filters.AlphaBetaFilter`
  (tested to agree to round-off), vectorised because per-track filterpy calls cost ~50 us each.
- `ObjectBank` holds one `StateFilter` object per track and loops: the way in for filters with no
  vectorised form (the robust Kalman filter of seed 001, the particle filters of seeds 002/003).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from tracker_filter.gains import GhGains, gain_schedule
from tracker_filter.linear_gaussian import correct, fixed_gain, innovation_covariance, kalman_gain
from tracker_filter.models import AXES, KinematicModel, LinearModel


class FilterBank(Protocol):
    """The filters of all tracks. `update` rows got a measurement; every other row missed one."""

    @property
    def state_layout(self) -> tuple[str, ...]: ...

    @property
    def time(self) -> float | None: ...

    @property
    def means(self) -> np.ndarray: ...  # (N, n)

    @property
    def covariances(self) -> np.ndarray: ...  # (N, n, n)

    def __len__(self) -> int: ...

    def predict(self, t: float) -> None: ...

    def measurement_prediction(self) -> tuple[np.ndarray, np.ndarray]: ...  # (N, 2), (N, 2, 2)

    def update(self, rows: np.ndarray, z: np.ndarray) -> None: ...

    def add(self, z: np.ndarray) -> None: ...  # new rows at the bank's time, one per position

    def keep(self, mask: np.ndarray) -> None: ...

    def clear(self) -> None: ...


class LinearGaussianBank:
    """Kalman (gains None) or fixed-gain (alpha-beta / alpha-beta-gamma) filters as stacked arrays."""

    def __init__(
        self,
        model: KinematicModel | LinearModel,
        measurement_noise: float,
        process_noise: float,
        initial_covariance: np.ndarray,
        gains: GhGains | None = None,
        startup: bool = True,
        measurement_covariance: np.ndarray | None = None,
    ) -> None:
        if gains is not None and gains.order != getattr(model, "order", None):
            raise ValueError("the gains' order must match the model's")
        self.model = model
        self.process_noise = process_noise
        self.measurement_covariance = (
            np.eye(AXES) * measurement_noise**2
            if measurement_covariance is None
            else np.asarray(measurement_covariance, dtype=float)
        )
        self.initial_covariance = np.asarray(initial_covariance, dtype=float)
        self.gains = gains
        self.startup = startup
        self._transition_cache: tuple[float, np.ndarray, np.ndarray] | None = None
        self.clear()

    def clear(self) -> None:
        n = self.model.dim
        self._means = np.zeros((0, n))
        self._covariances = np.zeros((0, n, n))
        self._measurements = np.zeros(0, dtype=np.int64)  # per row, for the start-up gains
        self._time: float | None = None
        self._dt = 0.0

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.model.state_layout

    @property
    def time(self) -> float | None:
        return self._time

    @property
    def means(self) -> np.ndarray:
        return self._means

    @property
    def covariances(self) -> np.ndarray:
        return self._covariances

    def __len__(self) -> int:
        return len(self._means)

    def _transition(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        if self._transition_cache is None or self._transition_cache[0] != dt:
            self._transition_cache = (
                dt,
                self.model.transition(dt),
                self.model.process_noise(dt, self.process_noise),
            )
        return self._transition_cache[1], self._transition_cache[2]

    def predict(self, t: float) -> None:
        if self._time is not None and not t >= self._time:
            raise ValueError(f"cannot predict from t = {self._time} s back to t = {t} s")
        dt = 0.0 if self._time is None else t - self._time
        if dt > 0.0 and len(self):
            transition, noise = self._transition(dt)
            self._means = self._means @ transition.T
            self._covariances = transition @ self._covariances @ transition.T + noise
        self._time = float(t)
        self._dt = dt

    def measurement_prediction(self) -> tuple[np.ndarray, np.ndarray]:
        return self._means[:, :AXES], innovation_covariance(
            self._covariances, self.measurement_covariance
        )

    def update(self, rows: np.ndarray, z: np.ndarray) -> None:
        # Rows without a measurement keep their prediction: a miss is a pure prediction.
        rows = np.asarray(rows, dtype=np.int64)
        if rows.size == 0:
            return
        covariances = self._covariances[rows]
        if self.gains is None:
            gain = kalman_gain(covariances, self.measurement_covariance)
        else:
            g, h, k = gain_schedule(self.gains, self._measurements[rows], self.startup)
            gain = fixed_gain(g, h, k, self._dt, self.gains.order)
        self._means[rows], self._covariances[rows] = correct(
            self._means[rows],
            covariances,
            np.asarray(z, dtype=float),
            gain,
            self.measurement_covariance,
        )
        self._measurements[rows] += 1

    def add(self, z: np.ndarray) -> None:
        z = np.asarray(z, dtype=float).reshape(-1, AXES)
        means = np.zeros((len(z), self.model.dim))
        means[:, :AXES] = z
        self._means = np.concatenate([self._means, means])
        self._covariances = np.concatenate(
            [
                self._covariances,
                np.broadcast_to(self.initial_covariance, (len(z),) + self.initial_covariance.shape),
            ]
        )
        self._measurements = np.concatenate([self._measurements, np.ones(len(z), dtype=np.int64)])

    def keep(self, mask: np.ndarray) -> None:
        self._means = self._means[mask]
        self._covariances = self._covariances[mask]
        self._measurements = self._measurements[mask]


class ObjectBank:
    """One `StateFilter` per row, made by `new_filter(z, t)` (e.g. `FilterConfig.new_filter`)."""

    def __init__(self, new_filter: Callable, state_layout: tuple[str, ...]) -> None:
        self._new_filter = new_filter
        self._state_layout = tuple(state_layout)
        self.clear()

    def clear(self) -> None:
        self.filters: list = []
        self._time: float | None = None

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self._state_layout

    @property
    def time(self) -> float | None:
        return self._time

    @property
    def means(self) -> np.ndarray:
        return np.array([f.mean for f in self.filters]).reshape(
            len(self.filters), len(self._state_layout)
        )

    @property
    def covariances(self) -> np.ndarray:
        n = len(self._state_layout)
        return np.array([f.covariance for f in self.filters]).reshape(len(self.filters), n, n)

    def __len__(self) -> int:
        return len(self.filters)

    def predict(self, t: float) -> None:
        if self._time is not None and not t >= self._time:
            raise ValueError(f"cannot predict from t = {self._time} s back to t = {t} s")
        for f in self.filters:
            f.predict(t)
        self._time = float(t)

    def measurement_prediction(self) -> tuple[np.ndarray, np.ndarray]:
        predictions = [f.measurement_prediction() for f in self.filters]
        z = np.array([p[0] for p in predictions]).reshape(-1, AXES)
        s = np.array([p[1] for p in predictions]).reshape(-1, AXES, AXES)
        return z, s

    def update(self, rows: np.ndarray, z: np.ndarray) -> None:
        measured = dict(
            zip(np.asarray(rows, dtype=int).tolist(), np.asarray(z, dtype=float), strict=True)
        )
        for row, f in enumerate(self.filters):
            f.update(measured.get(row))

    def add(self, z: np.ndarray) -> None:
        self.filters.extend(
            self._new_filter(position, self._time)
            for position in np.asarray(z, dtype=float).reshape(-1, AXES)
        )

    def keep(self, mask: np.ndarray) -> None:
        self.filters = [f for f, kept in zip(self.filters, mask, strict=True) if kept]
