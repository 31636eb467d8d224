"""The filter registry: the tracker's `filter` parameter picks one of these (no rclpy).

Each method builds a `filters.FilterFactory` (single filters and the vectorised bank) from the
filter parameters (`FilterParams`, declared once as its fields): seed 000's four filters on the
built-in kinematic models, and a Kalman filter on explicit matrices F, G, Q, R
(`models.LinearModel`; the defaults are seed 001's nominal filter). A new filter is a module with
its factory plus one `FILTERS.register` line here (and its parameters as `FilterParams` fields).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tracker_filter.filters import FilterConfig, FilterFactory, FilterKind, LinearModelFilterConfig
from tracker_filter.gains import GainRule, resolve_gains
from tracker_filter.models import LinearModel, seed001_nominal_model
from tracker_filter.robust_kalman import (
    LambdaRule,
    ModelUncertainty,
    RobustKalmanConfig,
    seed001_uncertainty,
)
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method, Registry

FILTERS: Registry[FilterFactory] = Registry("filter")


def kinematic_filter(kind: FilterKind, values: FilterParams) -> FilterConfig:
    """One of seed 000's filters from the filter parameters (raises ValueError)."""
    # the gains are checked whatever the filter, so a later switch to alpha-beta cannot fail
    order = kind.model.order if kind.fixed_gain else 1
    gains = resolve_gains(values.alpha, values.gain_rule, order, values.beta, values.gamma)
    initial_covariance = None
    if values.initial_covariance == "process_noise":
        initial_covariance = kind.model.process_noise(values.nominal_dt, values.process_noise)
    return FilterConfig(
        kind=kind,
        measurement_noise=values.measurement_noise,
        process_noise=values.process_noise,
        initial_velocity_std=values.initial_velocity_std,
        initial_acceleration_std=values.initial_acceleration_std,
        gains=gains if kind.fixed_gain else None,
        startup=values.startup_gains,
        initial_covariance=initial_covariance,
    )


def _square(name: str, values: tuple[float, ...] | list[float]) -> np.ndarray:
    side = round(len(values) ** 0.5)
    if side * side != len(values) or side == 0:
        raise ValueError(f"{name} needs a square matrix row by row, got {len(values)} numbers")
    return np.asarray(values, dtype=float).reshape(side, side)


def linear_model(values: FilterParams) -> LinearModel:
    """The explicit model of the model_* parameters (row-major matrices; raises ValueError)."""
    names = tuple(values.model_state_layout.split())
    n = len(names)
    gain = np.asarray(values.model_noise_gain, dtype=float)
    if names[:2] != ("x", "y"):
        raise ValueError("model_state_layout must start with x y (the measured position)")
    if gain.size % n:
        raise ValueError(f"model_noise_gain needs {n} rows (one per state element)")
    return LinearModel(
        _square("model_transition", values.model_transition),
        gain.reshape(n, -1),
        _square("model_process_covariance", values.model_process_covariance),
        _square("model_measurement_covariance", values.model_measurement_covariance),
        names,
    )


def model_uncertainty(values: FilterParams, model: LinearModel) -> ModelUncertainty:
    """M, E_f, E_g of the robust_* parameters (row-major; k = len(M) / n; raises ValueError)."""
    n, m = model.noise_gain.shape
    raw = {
        "m": np.asarray(values.robust_m, dtype=float),
        "e_f": np.asarray(values.robust_e_f, dtype=float),
        "e_g": np.asarray(values.robust_e_g, dtype=float),
    }
    if raw["m"].size == 0 or raw["m"].size % n:
        raise ValueError(f"robust_m needs {n} rows (one per state element)")
    k = raw["m"].size // n
    if raw["e_f"].size != k * n or raw["e_g"].size != k * m:
        raise ValueError(f"robust_e_f must be {k}x{n} and robust_e_g {k}x{m} (M is {n}x{k})")
    return ModelUncertainty(
        raw["m"].reshape(n, k), raw["e_f"].reshape(k, n), raw["e_g"].reshape(k, m)
    )


def robust_filter(values: FilterParams) -> RobustKalmanConfig:
    model = linear_model(values)
    return RobustKalmanConfig(
        model,
        model_uncertainty(values, model),
        LambdaRule(values.robust_lambda_rule),
        values.robust_alpha,
        values.initial_velocity_std,
        values.model_step == "stamps",
    )


for _kind in FilterKind:
    FILTERS.register(
        Method(
            name=_kind.value,
            description={
                FilterKind.ALPHA_BETA: "alpha-beta, constant velocity (seed 000)",
                FilterKind.ALPHA_BETA_GAMMA: "alpha-beta-gamma, constant acceleration",
                FilterKind.KALMAN_CV: "Kalman, constant velocity (seed 000)",
                FilterKind.KALMAN_CA: "Kalman, constant acceleration",
            }[_kind],
            build=lambda values, kind=_kind: kinematic_filter(kind, values),
        )
    )

FILTERS.register(
    Method(
        name="kalman_linear_model",
        description="Kalman on explicit F, G, Q, R (model_* parameters; default: seed 001's "
        "nominal filter), one step per frame",
        build=lambda values: LinearModelFilterConfig(
            linear_model(values), values.initial_velocity_std
        ),
    )
)

FILTERS.register(
    Method(
        name="robust_kalman",
        description="seed 001's robust Kalman filter (Sayed 2001) on the model_* model with the "
        "robust_* uncertainty, one step per frame (model_step frame) or over the stamps' "
        "interval (stamps)",
        build=robust_filter,
    )
)


_SEED001 = seed001_nominal_model()
_SEED001_UNCERTAINTY = seed001_uncertainty()


@dataclass(frozen=True)
class FilterParams:
    """The parameters of every track's filter (the tracker's `filter` and what it reads); the
    defaults are the suite's constant-velocity Kalman filter, and seed 001's nominal model and
    uncertainty for the model_* and robust_* ones."""

    filter: str = param(
        "kalman_cv",
        "filter of every track",
        choices=FILTERS.names(),
    )
    alpha: float = param(
        0.6,
        "alpha-beta(-gamma) position gain",
        min=0.0,
        max=2.0,
    )
    gain_rule: str = param(
        "kalata",
        "how beta (and gamma) follow from alpha",
        choices=tuple(r.value for r in GainRule),
    )
    beta: float = param(
        0.27,
        "velocity gain for gain_rule free",
        min=0.0,
        max=4.0,
    )
    gamma: float = param(
        0.02,
        "acceleration gain for gain_rule free (a += 2 gamma r / dt^2)",
        min=0.0,
        max=4.0,
    )
    startup_gains: bool = param(
        True,
        "alpha-beta(-gamma): least-squares gains for a track's first measurements",
    )
    process_noise: float = param(
        100.0,
        "px/s^2 white acceleration (cv) or px/s^3 jerk (ca) std",
        min=1e-06,
        max=1000000.0,
    )
    measurement_noise: float = param(
        2.0,
        "px, std of a detection centroid per axis",
        min=1e-06,
        max=10000.0,
    )
    initial_velocity_std: float = param(
        100.0,
        "px/s, velocity std of a new track",
        min=1e-06,
        max=1000000.0,
    )
    initial_acceleration_std: float = param(
        100.0,
        "px/s^2, acceleration std of a new track (ca)",
        min=1e-06,
        max=1000000.0,
    )
    initial_covariance: str = param(
        "stds",
        "new-track covariance: from the stds, or Q(nominal_dt) (seed 000)",
        choices=("stds", "process_noise"),
    )
    nominal_dt: float = param(
        0.12,
        "s, frame interval for initial_covariance process_noise",
        min=0.0001,
        max=10.0,
    )
    model_state_layout: str = param(
        " ".join(_SEED001.state_layout),
        "kalman_linear_model, robust_kalman: state element names, x y first",
    )
    model_transition: tuple[float, ...] = param(
        _SEED001.transition_matrix.ravel().tolist(),
        "kalman_linear_model, robust_kalman: F, row by row",
    )
    model_noise_gain: tuple[float, ...] = param(
        _SEED001.noise_gain.ravel().tolist(),
        "kalman_linear_model, robust_kalman: G (n rows), row by row",
    )
    model_process_covariance: tuple[float, ...] = param(
        _SEED001.process_covariance.ravel().tolist(),
        "kalman_linear_model, robust_kalman: Q, row by row",
    )
    model_measurement_covariance: tuple[float, ...] = param(
        _SEED001.measurement_covariance.ravel().tolist(),
        "kalman_linear_model, robust_kalman: R (2x2), px^2, row by row",
    )
    model_step: str = param(
        "frame",
        "robust_kalman: one step of model_transition per frame (frame, the thesis), or F the "
        "kinematic transition over each frame's interval from the stamps (stamps; x y vx vy "
        "[ax ay] states), which keeps velocities in px/s at any frame rate",
        choices=("frame", "stamps"),
    )
    robust_lambda_rule: str = param(
        "exact",
        "robust_kalman: lambda_hat = argmin G (exact), (1 + robust_alpha) lambda_l (cheap), 0"
        " (nominal)",
        choices=tuple(r.value for r in LambdaRule),
    )
    robust_alpha: float = param(
        0.5,
        "robust_kalman: alpha of the cheap rule",
        min=1e-06,
        max=1000000.0,
    )
    robust_m: tuple[float, ...] = param(
        _SEED001_UNCERTAINTY.M.ravel().tolist(),
        "robust_kalman: M (n rows, k columns), row by row",
    )
    robust_e_f: tuple[float, ...] = param(
        _SEED001_UNCERTAINTY.E_f.ravel().tolist(),
        "robust_kalman: E_f (k x n), row by row",
    )
    robust_e_g: tuple[float, ...] = param(
        _SEED001_UNCERTAINTY.E_g.ravel().tolist(),
        "robust_kalman: E_g (k x m), row by row",
    )

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """The gains and the explicit model are checked whatever the filter, so a later switch to
        another filter cannot fail."""
        try:
            FILTERS.get(self.filter).build(self)
            kinematic_filter(FilterKind.ALPHA_BETA_GAMMA, self)
            linear_model(self)
        except ValueError as error:
            return [str(error)]
        return []

    def factory(self) -> FilterFactory:
        """The chosen filter's factory."""
        factory: FilterFactory = FILTERS.get(self.filter).build(self)
        return factory
