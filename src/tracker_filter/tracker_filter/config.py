"""The tracker's configuration: flat parameters (the node's ROS parameters), named presets, and
validation into the objects of the core (no rclpy).

Presets:
- ``multi``: multi-target tracking with a constant-velocity Kalman filter (the default);
- ``seed000``: seed 000's single-target tracker with its alpha-beta filter (alpha 0.6, Kalata beta):
  largest detection only, one track, no gate, tracking from the first detection, reset after
  4 consecutive misses, window on the current estimate (lead 0);
- ``seed000_kalman``: the same with seed 000's Kalman filter. The seed used dt = 1.1 per processed
  frame, sigma_a = 0.3, R = I, P0 = Q; processed frames are 3/25 s apart, so in seconds sigma_a =
  0.3 (1.1 / 0.12)^2 px/s^2 and P0 = Q(0.12 s) give exactly the seed's positions.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from tracker_filter.association import GatedHungarianAssociator
from tracker_filter.filter_registry import FILTERS, kinematic_filter, linear_model
from tracker_filter.filters import FilterFactory, FilterKind
from tracker_filter.gains import GainRule
from tracker_filter.management import (
    AllDetections,
    BoxGate,
    CappedInitiator,
    LargestDetection,
    MergedSplitter,
    MissCountDeleter,
    MofNConfirmation,
    NoSplit,
    OverlapRecovery,
    TrackManager,
)
from tracker_filter.models import seed001_nominal_model
from tracker_filter.robust_kalman import LambdaRule, seed001_uncertainty
from tracker_filter.selection import (
    SELECTION_DEFAULTS,
    SELECTION_PARAMETERS,
    SelectionConfig,
    TargetSelector,
)
from tracker_msgs_py.labels import ANY_LABEL
from tracker_msgs_py.params import ParamSpec, config_from_params

SEED_CYCLE = 3.0 / 25.0  # s between processed frames in seed 000 (every 3rd frame at 25 fps)
SEED_DT = 1.1  # the prototype's dt per processed frame (digest section 3)
SEED_SIGMA_A = 0.3  # the prototype's acceleration noise in px per (prototype time unit)^2


def seed_process_noise(cycle: float = SEED_CYCLE) -> float:
    """The seed's sigma_a expressed in px/s^2 for frames `cycle` seconds apart."""
    return SEED_SIGMA_A * (SEED_DT / cycle) ** 2


_SEED001 = seed001_nominal_model()
_SEED001_UNCERTAINTY = seed001_uncertainty()

_MULTI: dict[str, Any] = {
    "filter": "kalman_cv",
    "alpha": 0.6,
    "gain_rule": "kalata",
    "beta": 0.27,
    "gamma": 0.02,
    "startup_gains": True,
    "process_noise": 100.0,
    "measurement_noise": 2.0,
    "initial_velocity_std": 100.0,
    "initial_acceleration_std": 100.0,
    "initial_covariance": "stds",
    "nominal_dt": SEED_CYCLE,
    # kalman_linear_model: seed 001's nominal constant-acceleration filter (T = 1/20 s)
    "model_state_layout": " ".join(_SEED001.state_layout),
    "model_transition": _SEED001.transition_matrix.ravel().tolist(),
    "model_noise_gain": _SEED001.noise_gain.ravel().tolist(),
    "model_process_covariance": _SEED001.process_covariance.ravel().tolist(),
    "model_measurement_covariance": _SEED001.measurement_covariance.ravel().tolist(),
    "model_step": "frame",
    # robust_kalman: seed 001's uncertainty [dF dG] = M Delta [E_f E_g]
    "robust_lambda_rule": LambdaRule.EXACT.value,
    "robust_alpha": 0.5,
    "robust_m": _SEED001_UNCERTAINTY.M.ravel().tolist(),
    "robust_e_f": _SEED001_UNCERTAINTY.E_f.ravel().tolist(),
    "robust_e_g": _SEED001_UNCERTAINTY.E_g.ravel().tolist(),
    "gate_probability": 0.99,
    "measurements": "all",
    "max_tracks": 100,
    "confirm_hits": 3,
    "confirm_window": 4,
    "confirm_travel": 0.0,
    "confirm_travel_window": 30,
    "confirm_straightness": 0.0,
    "straightness_step": 0.0,
    "confirm_min_height": 0.0,
    "confirm_height_ratio": 0.0,
    "max_misses": 12,
    "split_merged": 0.0,
    "recover_overlap": 0.0,
    "box_tolerance": 0.0,
    **SELECTION_DEFAULTS,  # lead_time: seed 000's cycle, SEED_CYCLE
}


def _spec(
    name: str,
    description: str,
    min: float | None = None,
    max: float | None = None,
    choices: tuple[str, ...] | None = None,
) -> ParamSpec:
    """A parameter whose default is the ``multi`` preset's value."""
    return ParamSpec(name, _MULTI[name], description, min, max, choices)


TRACKING_PARAMETERS: tuple[ParamSpec, ...] = (
    _spec("filter", "filter of every track", choices=FILTERS.names()),
    _spec("alpha", "alpha-beta(-gamma) position gain", 0.0, 2.0),
    _spec(
        "gain_rule",
        "how beta (and gamma) follow from alpha",
        choices=tuple(r.value for r in GainRule),
    ),
    _spec("beta", "velocity gain for gain_rule free", 0.0, 4.0),
    _spec("gamma", "acceleration gain for gain_rule free (a += 2 gamma r / dt^2)", 0.0, 4.0),
    _spec(
        "startup_gains", "alpha-beta(-gamma): least-squares gains for a track's first measurements"
    ),
    _spec("process_noise", "px/s^2 white acceleration (cv) or px/s^3 jerk (ca) std", 1e-6, 1e6),
    _spec("measurement_noise", "px, std of a detection centroid per axis", 1e-6, 1e4),
    _spec("initial_velocity_std", "px/s, velocity std of a new track", 1e-6, 1e6),
    _spec("initial_acceleration_std", "px/s^2, acceleration std of a new track (ca)", 1e-6, 1e6),
    _spec(
        "initial_covariance",
        "new-track covariance: from the stds, or Q(nominal_dt) (seed 000)",
        choices=("stds", "process_noise"),
    ),
    _spec("nominal_dt", "s, frame interval for initial_covariance process_noise", 1e-4, 10.0),
    _spec(
        "model_state_layout", "kalman_linear_model, robust_kalman: state element names, x y first"
    ),
    _spec("model_transition", "kalman_linear_model, robust_kalman: F, row by row"),
    _spec("model_noise_gain", "kalman_linear_model, robust_kalman: G (n rows), row by row"),
    _spec("model_process_covariance", "kalman_linear_model, robust_kalman: Q, row by row"),
    _spec(
        "model_measurement_covariance",
        "kalman_linear_model, robust_kalman: R (2x2), px^2, row by row",
    ),
    _spec(
        "model_step",
        "robust_kalman: one step of model_transition per frame (frame, the thesis), or F the "
        "kinematic transition over each frame's interval from the stamps (stamps; x y vx vy "
        "[ax ay] states), which keeps velocities in px/s at any frame rate",
        choices=("frame", "stamps"),
    ),
    _spec(
        "robust_lambda_rule",
        "robust_kalman: lambda_hat = argmin G (exact), (1 + robust_alpha) lambda_l (cheap), 0 (nominal)",
        choices=tuple(r.value for r in LambdaRule),
    ),
    _spec("robust_alpha", "robust_kalman: alpha of the cheap rule", 1e-6, 1e6),
    _spec("robust_m", "robust_kalman: M (n rows, k columns), row by row"),
    _spec("robust_e_f", "robust_kalman: E_f (k x n), row by row"),
    _spec("robust_e_g", "robust_kalman: E_g (k x m), row by row"),
    _spec("gate_probability", "chi-square gate probability; 1 = no gate", 0.5, 1.0),
    _spec(
        "measurements",
        "detections used: all, or the largest only (seed 000)",
        choices=("all", "largest"),
    ),
    _spec("max_tracks", "most tracks at once", 1, 10000),
    _spec("confirm_hits", "M: hits needed to confirm a track", 1, 100),
    _spec("confirm_window", "N: frames from initiation in which to collect M hits", 1, 100),
    _spec(
        "confirm_travel",
        "px a tentative track must move from where it began to be confirmed (0: no need)",
        0.0,
        10000.0,
    ),
    _spec(
        "confirm_travel_window",
        "frames a tentative track has to travel confirm_travel before it is dropped",
        1,
        10000,
    ),
    _spec(
        "confirm_straightness",
        "net distance / path of a tentative track's detections needed to confirm it (0: no need; "
        "a walker is near 1, a flutter in place near 0)",
        0.0,
        1.0,
    ),
    _spec(
        "straightness_step",
        "px between the waypoints of the path straightness is measured on (a blob's centroid "
        "jitters from frame to frame; 0: every detection)",
        0.0,
        10000.0,
    ),
    _spec(
        "confirm_min_height",
        "px a tentative track's box must be tall to be confirmed (0: any size; the least height "
        "of what is followed at this camera's scale)",
        0.0,
        10000.0,
    ),
    _spec(
        "confirm_height_ratio",
        "share of the height confirmed tracks have had where a tentative track stands (a line in "
        "the row of the box's bottom, learned as they are seen) its box needs to be confirmed "
        "(0: no need; a camera over a ground plane sees people smaller farther up the image)",
        0.0,
        1.0,
    ),
    _spec("max_misses", "consecutive missed frames before a track is lost", 1, 10000),
    _spec(
        "split_merged",
        "split a detection holding two or more confirmed tracks' predicted boxes into one piece "
        "per track when its box is at least this x the largest of theirs in area (0: never)",
        0.0,
        100.0,
    ),
    _spec(
        "recover_overlap",
        "pair a confirmed track and a detection the centroid gate kept apart when the track's "
        "predicted box and the detection's box overlap by at least this IoU (0: never)",
        0.0,
        1.0,
    ),
    _spec(
        "box_tolerance",
        "keep a track's box edge where the detection's moved more than this x its height "
        "(legs lost, a sign joined above) for up to 5 frames (0: boxes as detected)",
        0.0,
        10.0,
    ),
)

#: Every parameter of the gated-Hungarian tracker and the target selection.
PARAMETERS: tuple[ParamSpec, ...] = TRACKING_PARAMETERS + SELECTION_PARAMETERS

_SEED000 = _MULTI | {
    "filter": "alpha_beta",
    "startup_gains": False,
    "process_noise": seed_process_noise(),
    "measurement_noise": 1.0,
    "gate_probability": 1.0,
    "measurements": "largest",
    "max_tracks": 1,
    "confirm_hits": 1,
    "confirm_window": 1,
    "confirm_travel": 0.0,
    "confirm_straightness": 0.0,
    "max_misses": 4,
    "selection_policy": "largest_blob",
    "min_lock_time": 0.0,
    "lead_time": 0.0,
    "track_labels": [ANY_LABEL],  # the seed follows the largest blob, whatever it is
}

PRESETS: dict[str, dict[str, Any]] = {
    "multi": _MULTI,
    "seed000": _SEED000,
    "seed000_kalman": _SEED000 | {"filter": "kalman_cv", "initial_covariance": "process_noise"},
}


@dataclass(frozen=True, eq=False)
class TrackerConfig:
    """Everything the tracker node builds its core from."""

    filter: FilterFactory
    gate_probability: float
    measurements: str
    max_tracks: int
    confirm_hits: int
    confirm_window: int
    confirm_travel: float
    confirm_travel_window: int
    confirm_straightness: float
    straightness_step: float
    confirm_min_height: float
    confirm_height_ratio: float
    max_misses: int
    split_merged: float
    recover_overlap: float
    box_tolerance: float
    selection: SelectionConfig

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> TrackerConfig:
        """Validate a full set of parameters; raises ValueError naming the first problem."""
        missing = [info.name for info in PARAMETERS if info.name not in params]
        if missing:
            raise ValueError(f"missing parameters: {', '.join(missing)}")
        for spec in PARAMETERS:
            reason = spec.check(params[spec.name])
            if reason:
                raise ValueError(reason)
        filter_factory = FILTERS.get(params["filter"]).build(params)
        # the gains and the explicit model are checked whatever the filter, so a later switch
        # to another filter cannot fail
        kinematic_filter(FilterKind.ALPHA_BETA_GAMMA, params)
        linear_model(params)
        if params["confirm_hits"] > params["confirm_window"]:
            hits, window = params["confirm_hits"], params["confirm_window"]
            raise ValueError(f"confirm_hits ({hits}) must not exceed confirm_window ({window})")
        if 0.0 < params["split_merged"] < 1.0:
            raise ValueError(f"split_merged must be 0 (off) or >= 1, got {params['split_merged']}")
        return cls(
            filter=filter_factory,
            gate_probability=params["gate_probability"],
            measurements=params["measurements"],
            max_tracks=params["max_tracks"],
            confirm_hits=params["confirm_hits"],
            confirm_window=params["confirm_window"],
            confirm_travel=params["confirm_travel"],
            confirm_travel_window=params["confirm_travel_window"],
            confirm_straightness=params["confirm_straightness"],
            straightness_step=params["straightness_step"],
            confirm_min_height=params["confirm_min_height"],
            confirm_height_ratio=params["confirm_height_ratio"],
            max_misses=params["max_misses"],
            split_merged=params["split_merged"],
            recover_overlap=params["recover_overlap"],
            box_tolerance=params["box_tolerance"],
            selection=config_from_params(SelectionConfig, params),
        )

    @classmethod
    def preset(cls, name: str, **overrides: Any) -> TrackerConfig:
        if name not in PRESETS:
            raise ValueError(f"unknown preset '{name}' (one of {', '.join(PRESETS)})")
        return cls.from_params(PRESETS[name] | overrides)

    def build_tracker(self, first_id: int = 1) -> TrackManager:
        """A new tracker; `first_id` lets a rebuilt tracker continue its predecessor's ids."""
        confirmation = MofNConfirmation(
            self.confirm_hits,
            self.confirm_window,
            self.confirm_travel,
            self.confirm_travel_window,
            self.confirm_straightness,
            self.straightness_step,
            self.confirm_min_height,
            self.confirm_height_ratio,
        )
        return TrackManager(
            self.filter,
            GatedHungarianAssociator(self.gate_probability),
            CappedInitiator(self.max_tracks),
            confirmation,
            MissCountDeleter(self.max_misses),
            LargestDetection() if self.measurements == "largest" else AllDetections(),
            first_id=first_id,
            splitter=MergedSplitter(self.split_merged) if self.split_merged else NoSplit(),
            recovery=OverlapRecovery(self.recover_overlap) if self.recover_overlap else None,
            box_gate=(
                BoxGate(self.box_tolerance, scale=confirmation.scale)
                if self.box_tolerance
                else None
            ),
        )

    def build_selector(self) -> TargetSelector:
        return self.selection.selector()
