"""Frames opened by a driving stream are released once, when their parts have come or never will."""

from __future__ import annotations

from tracker_msgs_py.pairing import FrameAssembler


def stamps(frames):
    return [(f.stamp_ns, f.missing) for f in frames]


def test_without_needed_parts_every_frame_is_released_at_once():
    frames = FrameAssembler(())
    assert stamps(frames.add_primary(5, "a")) == [(5, ())]


def test_parts_before_or_after_the_frame_complete_it():
    frames = FrameAssembler(("image", "window"))
    assert frames.add_part("image", 1, "img1") == []
    assert frames.add_primary(1, "det1") == []
    released = frames.add_part("window", 1, "win1")
    assert stamps(released) == [(1, ())]
    assert (
        released[0].parts == {"image": "img1", "window": "win1"} and released[0].primary == "det1"
    )


def test_a_part_that_will_never_come_releases_the_frame_without_it_in_order():
    frames = FrameAssembler(("image",))
    assert frames.add_primary(1, "det1") == []
    assert frames.add_primary(2, "det2") == []
    released = frames.add_part("image", 2, "img2")  # image 1 was lost: stamps only go forward
    assert stamps(released) == [(1, ("image",)), (2, ())]
    assert released[0].parts == {"image": None}


def test_capacity_bounds_the_wait_and_clear_releases_the_rest():
    frames = FrameAssembler(("mask",), capacity=2)
    assert frames.add_primary(1, "a") == [] and frames.add_primary(2, "b") == []
    assert stamps(frames.add_primary(3, "c")) == [(1, ("mask",))]
    assert stamps(frames.clear()) == [(2, ("mask",)), (3, ("mask",))]
    assert len(frames) == 0
