"""The filter registry: the tracker's `filter` parameter picks one of these (no rclpy).

Each method builds a `filters.FilterFactory` (single filters and the vectorised bank) from the
tracker's parameter values: seed 000's four filters on the built-in kinematic models, and a Kalman
filter on explicit matrices F, G, Q, R (`models.LinearModel`; the defaults are seed 001's nominal
filter). A new filter is a module with its factory plus one `FILTERS.register` line here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from tracker_filter.filters import FilterConfig, FilterFactory, FilterKind, LinearModelFilterConfig
from tracker_filter.gains import resolve_gains
from tracker_filter.models import LinearModel
from tracker_filter.robust_kalman import ModelUncertainty, RobustKalmanConfig
from tracker_msgs_py.registry import Method, Registry

FILTERS: Registry[FilterFactory] = Registry("filter")


def kinematic_filter(kind: FilterKind, values: Mapping[str, Any]) -> FilterConfig:
    """One of seed 000's filters from the tracker's parameters (raises ValueError)."""
    # the gains are checked whatever the filter, so a later switch to alpha-beta cannot fail
    order = kind.model.order if kind.fixed_gain else 1
    gains = resolve_gains(
        values["alpha"], values["gain_rule"], order, values["beta"], values["gamma"]
    )
    initial_covariance = None
    if values["initial_covariance"] == "process_noise":
        initial_covariance = kind.model.process_noise(values["nominal_dt"], values["process_noise"])
    return FilterConfig(
        kind=kind,
        measurement_noise=values["measurement_noise"],
        process_noise=values["process_noise"],
        initial_velocity_std=values["initial_velocity_std"],
        initial_acceleration_std=values["initial_acceleration_std"],
        gains=gains if kind.fixed_gain else None,
        startup=values["startup_gains"],
        initial_covariance=initial_covariance,
    )


def _square(name: str, values: list[float]) -> np.ndarray:
    side = round(len(values) ** 0.5)
    if side * side != len(values) or side == 0:
        raise ValueError(f"{name} needs a square matrix row by row, got {len(values)} numbers")
    return np.asarray(values, dtype=float).reshape(side, side)


def linear_model(values: Mapping[str, Any]) -> LinearModel:
    """The explicit model of the model_* parameters (row-major matrices; raises ValueError)."""
    names = tuple(values["model_state_layout"].split())
    n = len(names)
    gain = np.asarray(values["model_noise_gain"], dtype=float)
    if names[:2] != ("x", "y"):
        raise ValueError("model_state_layout must start with x y (the measured position)")
    if gain.size % n:
        raise ValueError(f"model_noise_gain needs {n} rows (one per state element)")
    return LinearModel(
        _square("model_transition", values["model_transition"]),
        gain.reshape(n, -1),
        _square("model_process_covariance", values["model_process_covariance"]),
        _square("model_measurement_covariance", values["model_measurement_covariance"]),
        names,
    )


def model_uncertainty(values: Mapping[str, Any], model: LinearModel) -> ModelUncertainty:
    """M, E_f, E_g of the robust_* parameters (row-major; k = len(M) / n; raises ValueError)."""
    n, m = model.noise_gain.shape
    raw = {name: np.asarray(values[f"robust_{name}"], dtype=float) for name in ("m", "e_f", "e_g")}
    if raw["m"].size == 0 or raw["m"].size % n:
        raise ValueError(f"robust_m needs {n} rows (one per state element)")
    k = raw["m"].size // n
    if raw["e_f"].size != k * n or raw["e_g"].size != k * m:
        raise ValueError(f"robust_e_f must be {k}x{n} and robust_e_g {k}x{m} (M is {n}x{k})")
    return ModelUncertainty(
        raw["m"].reshape(n, k), raw["e_f"].reshape(k, n), raw["e_g"].reshape(k, m)
    )


def robust_filter(values: Mapping[str, Any]) -> RobustKalmanConfig:
    model = linear_model(values)
    return RobustKalmanConfig(
        model,
        model_uncertainty(values, model),
        values["robust_lambda_rule"],
        values["robust_alpha"],
        values["initial_velocity_std"],
        values["model_step"] == "stamps",
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
            linear_model(values), values["initial_velocity_std"]
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
