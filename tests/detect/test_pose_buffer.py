"""Pairing images with pan-tilt poses by stamp."""

from __future__ import annotations

import pytest

from tracker_detect.pose_buffer import PoseBuffer, PoseLookup, PoseStatus

MS = 1_000_000


def test_exact_stamp_is_found_in_any_arrival_order():
    buffer = PoseBuffer(capacity=8)
    buffer.add(200 * MS, (2.0, 20.0))
    buffer.add(100 * MS, (1.0, 10.0))  # late arrival of an older pose
    assert buffer.lookup(100 * MS).values == (1.0, 10.0)
    assert buffer.lookup(200 * MS).values == (2.0, 20.0)
    assert buffer.newest_stamp == 200 * MS


def test_images_newer_than_every_pose_wait():
    buffer = PoseBuffer()
    assert buffer.lookup(5).status is PoseStatus.WAIT
    buffer.add(100, (0.0,))
    assert buffer.lookup(101).status is PoseStatus.WAIT


def test_interpolates_between_close_poses_only():
    buffer = PoseBuffer(max_gap_ns=50 * MS)
    buffer.add(0, (0.0, 10.0))
    buffer.add(40 * MS, (4.0, 30.0))
    buffer.add(200 * MS, (9.0, 9.0))
    found = buffer.lookup(10 * MS)
    assert found.status is PoseStatus.FOUND
    assert found.values == pytest.approx((1.0, 15.0))
    assert buffer.lookup(100 * MS).status is PoseStatus.MISSING  # poses 160 ms apart
    exact_only = PoseBuffer()
    exact_only.add(0, (0.0,))
    exact_only.add(40 * MS, (4.0,))
    assert exact_only.lookup(10 * MS).status is PoseStatus.MISSING


def test_older_than_every_pose_is_missing_and_capacity_evicts_the_oldest():
    buffer = PoseBuffer(capacity=3)
    for k in range(5):
        buffer.add(k * MS, (float(k),))
    assert len(buffer) == 3
    assert buffer.lookup(1 * MS).status is PoseStatus.MISSING
    assert buffer.lookup(2 * MS).values == (2.0,)


def test_repeated_stamp_replaces_and_bad_values_are_rejected():
    buffer = PoseBuffer()
    buffer.add(7, (1.0,))
    buffer.add(7, (2.0,))
    assert len(buffer) == 1 and buffer.lookup(7).values == (2.0,)
    with pytest.raises(ValueError):
        buffer.add(8, (float("nan"),))
    assert len(buffer) == 1
    with pytest.raises(ValueError):
        PoseBuffer(capacity=1)


def test_a_new_epoch_drops_the_newer_poses():
    buffer = PoseBuffer(capacity=10)
    for k in range(5):
        buffer.add(k * 100, (float(k),))
    assert buffer.drop_after(150) == 3
    assert buffer.newest_stamp == 100
    buffer.add(120, (9.0,))
    assert buffer.lookup(120) == PoseLookup(PoseStatus.FOUND, (9.0,))
