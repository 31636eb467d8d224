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

from tracker_filter.filter_registry import FilterParams
from tracker_filter.filters import FilterFactory
from tracker_filter.gated_hungarian.association import GatedHungarianAssociator
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
from tracker_filter.selection import (
    SELECTION_DEFAULTS,
    SELECTION_PARAMETERS,
    SelectionConfig,
    TargetSelector,
)
from tracker_msgs_py.labels import ANY_LABEL
from tracker_msgs_py.params import (
    ParamSpec,
    check_config,
    config_from_params,
    param,
    params_of,
    specs_of,
)
from tracker_msgs_py.registry import Method

SEED_CYCLE = 3.0 / 25.0  # s between processed frames in seed 000 (every 3rd frame at 25 fps)
SEED_DT = 1.1  # the prototype's dt per processed frame (digest section 3)
SEED_SIGMA_A = 0.3  # the prototype's acceleration noise in px per (prototype time unit)^2


def seed_process_noise(cycle: float = SEED_CYCLE) -> float:
    """The seed's sigma_a expressed in px/s^2 for frames `cycle` seconds apart."""
    return SEED_SIGMA_A * (SEED_DT / cycle) ** 2


@dataclass(frozen=True)
class GatedHungarianConfig:
    """The gated-Hungarian tracker's parameters: its filters', then its association's and track
    management's; the defaults are the `multi` preset."""

    filters: FilterParams = params_of(FilterParams)
    gate_probability: float = param(
        0.99,
        "chi-square gate probability; 1 = no gate",
        min=0.5,
        max=1.0,
    )
    measurements: str = param(
        "all",
        "detections used: all, or the largest only (seed 000)",
        choices=("all", "largest"),
    )
    max_tracks: int = param(
        100,
        "most tracks at once",
        min=1,
        max=10000,
    )
    confirm_hits: int = param(
        3,
        "M: hits needed to confirm a track",
        min=1,
        max=100,
    )
    confirm_window: int = param(
        4,
        "N: frames from initiation in which to collect M hits",
        min=1,
        max=100,
    )
    confirm_travel: float = param(
        0.0,
        "px a tentative track must move from where it began to be confirmed (0: no need)",
        min=0.0,
        max=10000.0,
    )
    confirm_travel_window: int = param(
        30,
        "frames a tentative track has to travel confirm_travel before it is dropped",
        min=1,
        max=10000,
    )
    confirm_straightness: float = param(
        0.0,
        "net distance / path of a tentative track's detections needed to confirm it (0: no "
        "need; a walker is near 1, a flutter in place near 0)",
        min=0.0,
        max=1.0,
    )
    straightness_step: float = param(
        0.0,
        "px between the waypoints of the path straightness is measured on (a blob's centroid "
        "jitters from frame to frame; 0: every detection)",
        min=0.0,
        max=10000.0,
    )
    confirm_min_height: float = param(
        0.0,
        "px a tentative track's box must be tall to be confirmed (0: any size; the least "
        "height of what is followed at this camera's scale)",
        min=0.0,
        max=10000.0,
    )
    confirm_height_ratio: float = param(
        0.0,
        "share of the height confirmed tracks have had where a tentative track stands (a line"
        " in the row of the box's bottom, learned as they are seen) its box needs to be "
        "confirmed (0: no need; a camera over a ground plane sees people smaller farther up "
        "the image)",
        min=0.0,
        max=1.0,
    )
    max_misses: int = param(
        12,
        "consecutive missed frames before a track is lost",
        min=1,
        max=10000,
    )
    split_merged: float = param(
        0.0,
        "split a detection holding two or more confirmed tracks' predicted boxes into one "
        "piece per track when its box is at least this x the largest of theirs in area (0: "
        "never)",
        min=0.0,
        max=100.0,
    )
    recover_overlap: float = param(
        0.0,
        "pair a confirmed track and a detection the centroid gate kept apart when the track's"
        " predicted box and the detection's box overlap by at least this IoU (0: never)",
        min=0.0,
        max=1.0,
    )
    box_tolerance: float = param(
        0.0,
        "keep a track's box edge where the detection's moved more than this x its height "
        "(legs lost, a sign joined above) for up to 5 frames (0: boxes as detected)",
        min=0.0,
        max=10.0,
    )

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        found = []
        if self.confirm_hits > self.confirm_window:
            found.append(
                f"confirm_hits ({self.confirm_hits}) must not exceed confirm_window "
                f"({self.confirm_window})"
            )
        if 0.0 < self.split_merged < 1.0:
            found.append(f"split_merged must be 0 (off) or >= 1, got {self.split_merged}")
        return found


#: The gated-Hungarian tracker's own parameters (the target selection's are shared).
TRACKING_PARAMETERS: tuple[ParamSpec, ...] = specs_of(GatedHungarianConfig)

_MULTI: dict[str, Any] = {spec.name: spec.default for spec in TRACKING_PARAMETERS} | {
    **SELECTION_DEFAULTS,
    "lead_time": SEED_CYCLE,
}

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

    tracking: GatedHungarianConfig
    filter: FilterFactory
    selection: SelectionConfig

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> TrackerConfig:
        """Validate a full set of parameters; raises ValueError naming the problems."""
        missing = [info.name for info in PARAMETERS if info.name not in params]
        if missing:
            raise ValueError(f"missing parameters: {', '.join(missing)}")
        tracking = config_from_params(GatedHungarianConfig, params)
        return cls(
            tracking=tracking,
            filter=tracking.filters.factory(),
            selection=config_from_params(SelectionConfig, params),
        )

    @classmethod
    def preset(cls, name: str, **overrides: Any) -> TrackerConfig:
        if name not in PRESETS:
            raise ValueError(f"unknown preset '{name}' (one of {', '.join(PRESETS)})")
        return cls.from_params(PRESETS[name] | overrides)

    def build_tracker(self, first_id: int = 1) -> TrackManager:
        """A new tracker; `first_id` lets a rebuilt tracker continue its predecessor's ids."""
        return gated_hungarian_tracker(self.tracking, first_id, self.filter)

    def build_selector(self) -> TargetSelector:
        return self.selection.selector()


def gated_hungarian_tracker(
    config: GatedHungarianConfig, first_id: int = 1, filters: FilterFactory | None = None
) -> TrackManager:
    """The tracker `config` describes (`filters`: its filter factory, when already made)."""
    confirmation = MofNConfirmation(
        config.confirm_hits,
        config.confirm_window,
        config.confirm_travel,
        config.confirm_travel_window,
        config.confirm_straightness,
        config.straightness_step,
        config.confirm_min_height,
        config.confirm_height_ratio,
    )
    tolerance = config.box_tolerance
    return TrackManager(
        filters or config.filters.factory(),
        GatedHungarianAssociator(config.gate_probability),
        CappedInitiator(config.max_tracks),
        confirmation,
        MissCountDeleter(config.max_misses),
        LargestDetection() if config.measurements == "largest" else AllDetections(),
        first_id=first_id,
        splitter=MergedSplitter(config.split_merged) if config.split_merged else NoSplit(),
        recovery=OverlapRecovery(config.recover_overlap) if config.recover_overlap else None,
        box_gate=BoxGate(tolerance, scale=confirmation.scale) if tolerance else None,
    )


METHOD: Method[TrackManager] = Method.of(
    name="gated_hungarian",
    description="per-track alpha-beta / Kalman filters, chi-square gating, Hungarian "
    "assignment, M-of-N confirmation, deletion after consecutive misses (seed 000)",
    config=GatedHungarianConfig,
    make=gated_hungarian_tracker,
    presets=PRESETS,  # they also set the target selection for the node
)
