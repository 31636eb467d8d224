"""Presets and parameter validation of the tracker configuration."""

import math

import pytest

from tracker_filter.gated_hungarian.config import (
    PARAMETERS,
    PRESETS,
    TrackerConfig,
    seed_process_noise,
)
from tracker_filter.management import LargestDetection
from tracker_filter.selection import SelectionPolicy


def test_every_preset_is_valid_and_documents_every_parameter():
    names = {info.name for info in PARAMETERS}
    for name, values in PRESETS.items():
        assert set(values) == names, name
        TrackerConfig.preset(name)


def test_seed_preset_is_the_single_target_configuration():
    config = TrackerConfig.preset("seed000")
    tracker = config.build_tracker()
    assert isinstance(tracker.selector, LargestDetection)
    assert tracker.initiator.max_tracks == 1
    assert tracker.associator.gate == math.inf
    assert (tracker.confirmation.hits, tracker.confirmation.window) == (1, 1)
    assert tracker.deleter.max_misses == 4
    assert config.filter.gains.as_tuple() == pytest.approx((0.6, 0.2702), abs=1e-4)
    assert config.build_selector().policy == SelectionPolicy.LARGEST_BLOB
    kalman = TrackerConfig.preset("seed000_kalman").filter
    q = kalman.model.process_noise(0.12, seed_process_noise())
    assert (kalman.initial_state_covariance() == q).all()


@pytest.mark.parametrize(
    ("overrides", "reason"),
    [
        ({"confirm_hits": 5, "confirm_window": 3}, "must not exceed confirm_window"),
        ({"filter": "alpha_beta", "alpha": 1.5}, "0 < alpha < 1"),
        ({"filter": "alpha_beta_gamma", "gain_rule": "benedict_bordner"}, "alpha-beta only"),
        ({"filter": "alpha_beta", "gain_rule": "free", "alpha": 1.0, "beta": 2.5}, "unstable"),
        ({"filter": "particle"}, "filter must be one of"),
        ({"process_noise": float("nan")}, "finite"),
        ({"gate_probability": 0.2}, r"gate_probability must be in \[0.5, 1.0\]"),
    ],
)
def test_bad_parameters_are_rejected_with_a_reason(overrides, reason):
    with pytest.raises(ValueError, match=reason):
        TrackerConfig.preset("multi", **overrides)


def test_unknown_preset_and_missing_parameters():
    with pytest.raises(ValueError, match="unknown preset"):
        TrackerConfig.preset("nope")
    with pytest.raises(ValueError, match="missing parameters: alpha"):
        TrackerConfig.from_params({k: v for k, v in PRESETS["multi"].items() if k != "alpha"})
