"""TargetGate: a seeded detector's image waits for the hand-over target of its stamp and for its
own tracker's answer to the image before it; released in order, once, with its hand-over."""

from __future__ import annotations

import pytest

from tracker_detect.target_gate import TargetGate


def stamps(released) -> list[int]:
    return [held.stamp_ns for held in released]


def test_an_image_waits_for_the_handover_of_its_own_stamp():
    gate = TargetGate(handover=True, guide=False)
    assert gate.add_image(1, "image 1", 0.0) == []
    assert gate.add_handover(0, "older", 0.0) == []  # an older answer says nothing about 1
    released = gate.add_handover(1, "target 1", 0.0)
    assert stamps(released) == [1] and released[0].handover == "target 1"
    assert released[0].item == "image 1" and not released[0].timed_out


def test_a_newer_handover_releases_an_image_whose_own_never_came():
    gate = TargetGate(handover=True, guide=False)
    gate.add_image(1, "image 1", 0.0)
    gate.add_image(2, "image 2", 0.0)
    released = gate.add_handover(2, "target 2", 0.0)
    assert stamps(released) == [1, 2]
    assert [h.handover for h in released] == [None, "target 2"]


def test_a_handover_that_came_first_is_kept_for_its_image():
    gate = TargetGate(handover=True, guide=False)
    assert gate.add_handover(5, "target 5", 0.0) == []
    released = gate.add_image(5, "image 5", 0.0)
    assert stamps(released) == [5] and released[0].handover == "target 5"


def test_an_image_waits_for_the_own_trackers_answer_to_the_image_before():
    gate = TargetGate(handover=False, guide=True)
    assert stamps(gate.add_image(1, "image 1", 0.0)) == [1]  # the first image has none before it
    assert gate.add_image(2, "image 2", 0.0) == []
    assert stamps(gate.add_guide(1, 0.0)) == [2]
    assert gate.add_image(3, "image 3", 0.0) == []
    assert gate.add_guide(1, 0.0) == []  # a repeat of the old answer
    assert stamps(gate.add_guide(2, 0.0)) == [3]


def test_both_streams_in_any_order_release_each_image_once_in_order():
    gate = TargetGate(handover=True, guide=True)
    out = []
    out += gate.add_image(10, "a", 0.0)
    out += gate.add_handover(10, "h10", 0.0)
    out += gate.add_image(20, "b", 0.0)
    out += gate.add_guide(10, 0.0)  # b still needs its hand-over
    out += gate.add_image(30, "c", 0.0)
    out += gate.add_handover(30, "h30", 0.0)  # b's will not come now; c needs b's answer
    out += gate.add_guide(20, 0.0)
    assert stamps(out) == [10, 20, 30]
    assert [h.handover for h in out] == ["h10", None, "h30"]
    assert len(gate) == 0


def test_a_tracker_that_is_down_costs_at_most_the_timeout():
    gate = TargetGate(handover=True, guide=False, timeout=0.5)
    gate.add_image(1, "image 1", 10.0)
    assert gate.expire(10.4) == []
    released = gate.expire(10.5)
    assert stamps(released) == [1] and released[0].timed_out and released[0].handover is None


def test_capacity_bounds_the_wait():
    gate = TargetGate(handover=True, guide=False, capacity=2)
    assert gate.add_image(1, 1, 0.0) == [] and gate.add_image(2, 2, 0.0) == []
    assert stamps(gate.add_image(3, 3, 0.0)) == [1]


def test_clear_releases_what_waits_and_forgets_the_targets():
    gate = TargetGate(handover=True, guide=True)
    gate.add_handover(3, "h3", 0.0)
    assert gate.add_image(5, "image 5", 0.0) == []
    assert stamps(gate.clear()) == [5] and len(gate) == 0
    assert gate.add_image(3, "image 3 again", 0.0) == []  # h3 belonged to the old epoch


def test_bad_settings_are_refused():
    with pytest.raises(ValueError):
        TargetGate(True, True, timeout=0.0)
    with pytest.raises(ValueError):
        TargetGate(True, True, capacity=0)
