"""Seed 004's synthetic scenarios and the gm_phd tracker's accuracy on them (5 Monte Carlo seeds).

Floors are the values measured on these seeds (see README, `phd_benchmark`) less a margin; the
comparison with and without occlusion handling is the seed's claim: occlusions are not missed.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from tracker_filter.gm_phd.gmphd_tracker import GmPhdTracker
from tracker_ptz_sim.bringup.phd_benchmark import (
    gm_phd_scan_tracker,
    missed_draws,
    scenario_parameters,
)
from tracker_ptz_sim.evaluation import phd_scenarios
from tracker_ptz_sim.evaluation.phd_scenarios import AREA, STEPS, Summary

SEEDS = range(5)


def test_scenario_two_crosses_at_the_centre_and_scenario_three_has_eleven_births():
    two = phd_scenarios.scenario(2)
    assert np.allclose(two.positions[24], [[0.0, 500.0]] * 3)
    three = phd_scenarios.scenario(3)
    born = [int(np.flatnonzero(np.isfinite(three.positions[:, i, 0]))[0]) + 1 for i in range(11)]
    assert sorted(born) == [1, 1, 6, 6, 11, 11, 16, 16, 21, 21, 26]
    alive = three.positions[np.isfinite(three.positions[..., 0])]
    assert (alive[:, 0] >= AREA[0]).all() and (alive[:, 1] <= AREA[3]).all()
    one = phd_scenarios.scenario(1)
    assert np.allclose(one.positions[24, 2], [0.0, 500.0])  # born inside the crossing


def test_scans_merge_close_targets_and_add_the_clutter():
    case = phd_scenarios.scenario(2)
    draw = phd_scenarios.scans(case, seed=0)
    assert len(draw.measurements) == STEPS
    assert all(len(z) <= case.clutter + 3 for z in draw.measurements)
    assert len(draw.measurements[24]) <= case.clutter + 1  # one blob at the crossing
    assert {target for target, _, _ in draw.occlusions} == {1, 2, 3}


def evaluate(number: int, occlusion_handling: bool) -> Summary:
    case = phd_scenarios.scenario(number)
    values = scenario_parameters(case, occlusion_handling)
    return phd_scenarios.monte_carlo(case, SEEDS, partial(gm_phd_scan_tracker, values))


@pytest.mark.parametrize(
    ("number", "mota", "ospa", "missed_share"),
    [(1, 0.78, 55.0, 0.35), (2, 0.78, 40.0, 0.35), (3, 0.78, 70.0, 0.15)],
)
def test_gm_phd_tracks_the_scenarios(number, mota, ospa, missed_share):
    found = evaluate(number, occlusion_handling=True)
    assert found.mota >= mota
    assert found.ospa <= ospa
    assert found.missed_occlusions <= missed_share * found.occlusions
    assert sum(found.missed_by_seed.values()) == found.missed_occlusions
    assert set(found.missed_by_seed) <= set(SEEDS)


@pytest.mark.parametrize("number", [1, 2])
def test_occlusion_handling_keeps_labels_through_crossings(number):
    handled = evaluate(number, occlusion_handling=True)
    plain = evaluate(number, occlusion_handling=False)
    assert handled.missed_occlusions < plain.missed_occlusions / 2
    assert handled.idf1 > plain.idf1 + 0.1
    # the draws that missed one are named, each with its count
    assert sum(plain.missed_by_seed.values()) == plain.missed_occlusions > 0
    assert all(count > 0 for count in plain.missed_by_seed.values())
    line = missed_draws({number: plain})
    assert all(str(seed) in line for seed in plain.missed_by_seed)


@pytest.mark.parametrize("seed", [4, 27])
def test_labels_that_a_splitting_blob_gave_away_are_stitched_back(seed, monkeypatch):
    """Scenario 1, draws where a false alarm beside the blob ended the occlusion early: the
    blob's label went on with the third target and the crossing target it had came out as a
    new track. Stitching gives the label back to the track that fits its kept speed and
    heading, within the 3 frames the missed-occlusion count allows. (Placing the partner by its
    dead reckoning when the hidden track comes out now keeps these labels first; it is off here,
    to show what stitching alone does.)"""
    monkeypatch.setattr(GmPhdTracker, "_reckon_partners", lambda *_: None)
    case = phd_scenarios.scenario(1)

    def scores(stitch_frames: int):
        values = scenario_parameters(case) | {"stitch_frames": stitch_frames}
        return phd_scenarios.run(case, seed, gm_phd_scan_tracker(values)).scores

    stitched, plain = scores(5), scores(0)
    assert plain.missed_occlusions == 1 and stitched.missed_occlusions == 0
    assert stitched.idf1 > plain.idf1 + 0.1


@pytest.mark.parametrize("seed", [15, 22])
def test_a_track_pulled_off_course_before_the_blob_hides_it_is_still_taken_as_hidden(
    seed, monkeypatch
):
    """Scenario 2 (three targets crossing at one point), draws where a track was pulled more
    than an object size off the blob that then hid its target (in draw 22 by a 3.6 sigma
    measurement two frames before): judged at its predicted state it was not hidden, and was
    lost; judged at its dead reckoning too (it had come near another track) it is kept through
    the crossing with its label."""
    case = phd_scenarios.scenario(2)

    def missed(**changes: float) -> int:
        tracker = gm_phd_scan_tracker(scenario_parameters(case) | changes)
        return phd_scenarios.run(case, seed, tracker).scores.missed_occlusions

    # on the tracker's default 10-hit line (the benchmark's 15-hit line keeps this draw anyway);
    # the rule alone keeps it (a bridged miss also does)
    plain = {"bridge_missed": False, "velocity_history": 10}
    assert missed() == 0
    assert missed(**plain) == 0
    monkeypatch.setattr(GmPhdTracker, "_begin_reckoned", lambda *_: [])
    assert missed(**plain) >= 1


def test_a_target_missed_once_before_the_crossing_keeps_its_label_through_it():
    """Scenario 1, draw 9: one crossing target went undetected (p_D 0.98) six steps before
    the blob, and its Gaussian faded to 1 - p_D of its weight; found again only inside the
    crossing, as a new track, it had no label in the three steps before it. Bridging that one
    missed detection keeps its track, and its label comes through the crossing."""
    case = phd_scenarios.scenario(1)

    def missed(bridge: bool) -> int:
        values = scenario_parameters(case) | {"bridge_missed": bridge}
        return phd_scenarios.run(case, 9, gm_phd_scan_tracker(values)).scores.missed_occlusions

    assert missed(bridge=False) == 1 and missed(bridge=True) == 0


def test_a_partner_that_followed_the_blob_is_labelled_by_its_own_line_when_it_comes_apart(
    monkeypatch,
):
    """Scenario 1, draw 10: the hidden track came out while its partner's target and the one
    born in the crossing were still one blob; the partner's state followed that blob, which went
    on as the newborn target, and its label went with it. Placed by its dead reckoning for the
    next frame's labelling, the partner takes its own target's measurement (on the tracker's
    default 10-hit line; the benchmark's 15-hit line keeps this draw anyway)."""
    case = phd_scenarios.scenario(1)

    def missed() -> int:
        values = scenario_parameters(case) | {"velocity_history": 10}
        return phd_scenarios.run(case, 10, gm_phd_scan_tracker(values)).scores.missed_occlusions

    assert missed() == 0
    monkeypatch.setattr(GmPhdTracker, "_reckon_partners", lambda *_: None)
    assert missed() == 1


def test_the_benchmark_scores_the_seeds_it_is_given(tmp_path):
    from tracker_ptz_sim.bringup.phd_benchmark import main

    assert (
        main(["--scenarios", "2", "--first-seed", "50", "--seeds", "2", "--out", str(tmp_path)])
        == 0
    )
    table = (tmp_path / "table.md").read_text()
    assert "2 Monte Carlo runs per scenario (seeds 50-51)." in table
    assert table.count("\n| 2 |") == 1
