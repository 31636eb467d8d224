"""Cutting a mask between people side by side (`tracker_detect.side_by_side`) and the
background detector's `split_depth`."""

from __future__ import annotations

import cv2
import numpy as np

from tracker_detect.background import BackgroundConfig, BackgroundDetector
from tracker_detect.detector import CameraFrame
from tracker_detect.side_by_side import cut_side_by_side, top_outline, valley_columns
from tracker_msgs_py.geometry import Rect

NS = 100_000_000


def draw_person(mask: np.ndarray, x: int, top: int, height: int) -> Rect:
    """A standing silhouette `height` px tall whose box starts at column x: a head (a disc of
    0.14 x height) on a neck, a torso with round shoulders 0.36 x height wide, legs apart at the feet."""
    width = round(0.36 * height)
    centre = x + width // 2
    head = round(0.07 * height)
    cv2.circle(mask, (centre, top + head), head, 255, -1)
    neck = round(0.04 * height)
    cv2.rectangle(mask, (centre - neck, top + head), (centre + neck, top + 4 * head), 255, -1)
    torso = (centre, top + round(0.4 * height))  # shoulders 0.18 x height below the head's top
    cv2.ellipse(mask, torso, (width // 2, round(0.22 * height)), 0, 0, 360, 255, -1)
    hips, feet = top + round(0.55 * height), top + height - 1
    for foot in (x + 2, x + width - 7):
        leg = np.array([[centre - 4, hips], [centre + 4, hips], [foot + 5, feet], [foot, feet]])
        cv2.fillPoly(mask, [leg], 255)
    return Rect(x, top, width, height)


def boxes_of(mask: np.ndarray) -> list[Rect]:
    count, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    return sorted(
        (Rect(*(float(v) for v in stats[i, :4])) for i in range(1, count)), key=lambda r: r.x
    )


def test_two_people_side_by_side_are_cut_apart():
    """Two 100 px people whose bodies touch make one blob 0.7 x as wide as tall; cut at the dip
    of its outline between their heads, each piece is one person's box."""
    mask = np.zeros((160, 200), np.uint8)
    left = draw_person(mask, 40, 30, 100)
    right = draw_person(mask, 72, 32, 98)  # a step behind: slightly smaller, bodies overlap
    assert len(boxes_of(mask)) == 1
    pieces = boxes_of(cut_side_by_side(mask, depth=0.2))
    assert len(pieces) == 2
    assert pieces[0].iou(left) >= 0.8 and pieces[1].iou(right) >= 0.8


def test_three_abreast_make_three_pieces():
    mask = np.zeros((160, 260), np.uint8)
    people = [draw_person(mask, 30 + 33 * k, 30, 100) for k in range(3)]
    pieces = boxes_of(cut_side_by_side(mask, depth=0.2))
    assert len(pieces) == 3
    assert all(p.iou(q) >= 0.75 for p, q in zip(pieces, people, strict=True))


def test_a_lone_person_and_flat_or_narrow_blobs_are_left_whole():
    """A person's outline falls from the head to the shoulders: no dip with a higher point on
    both sides. A narrow blob is not looked at; the input array itself comes back."""
    mask = np.zeros((160, 200), np.uint8)
    draw_person(mask, 40, 30, 100)
    mask[150:156, 20:180] = 255  # a strip lying flat: its outline is level
    assert cut_side_by_side(mask, depth=0.2) is mask
    wide_stance = np.zeros((160, 200), np.uint8)
    draw_person(wide_stance, 40, 30, 100)
    cv2.rectangle(wide_stance, (20, 120), (110, 129), 255, -1)  # feet far apart
    assert cut_side_by_side(wide_stance, depth=0.2) is wide_stance


def test_a_person_is_cut_from_tape_that_rises_beside_them():
    """A strip of tape hanging from a post beside a person rises to their head's height: the
    dip between them is a cut, the person's piece is their box."""
    mask = np.zeros((160, 220), np.uint8)
    person = draw_person(mask, 40, 30, 100)
    tape = np.array([[60, 90], [180, 28], [180, 36], [60, 98]])
    cv2.fillPoly(mask, [tape], 255)
    pieces = boxes_of(cut_side_by_side(mask, depth=0.2))
    assert max(p.iou(person) for p in pieces) >= 0.6


def test_the_dip_must_be_deep_enough_and_both_sides_wide_enough():
    level = np.zeros(60)
    dip = level.copy()
    dip[24:36] = 15  # 15 % of a 100 px blob
    assert valley_columns(dip, 100, depth=0.2) == []
    assert valley_columns(dip, 100, depth=0.1) == [28]
    narrow = level.copy()
    narrow[5:8] = 40  # a dip 5 columns from the edge: that side is an arm, not a person
    assert valley_columns(narrow, 100, depth=0.2) == []


def test_top_outline_is_each_columns_highest_pixel():
    component = np.zeros((5, 3), bool)
    component[2:, 0] = True
    component[4, 2] = True
    assert top_outline(component).tolist() == [2, 5, 4]


def test_the_detector_splits_a_pair_walking_together():
    """Two people walking side by side over a textured ground: with split_depth 0.2 the
    background detector gives one box per person; without, one box over both."""
    rng = np.random.default_rng(5)
    ground = cv2.GaussianBlur(rng.integers(0, 255, (200, 320), dtype=np.uint8), (0, 0), 2)
    split = BackgroundDetector(BackgroundConfig(split_depth=0.2, min_aspect=0.5))
    whole = BackgroundDetector(BackgroundConfig(min_aspect=0.5))
    for k in range(50):
        silhouettes = np.zeros_like(ground)
        x = 20 + 3 * k
        people = [draw_person(silhouettes, x, 40, 100), draw_person(silhouettes, x + 35, 42, 98)]
        image = ground.copy()
        image[silhouettes > 0] = 30
        pieces = split.process(CameraFrame(k * NS, image)).blobs
        one = whole.process(CameraFrame(k * NS, image)).blobs
        if k >= 40:  # the ghosts of where they stood in the first frames have healed
            assert len(pieces) == 2
            assert all(max(b.bbox.iou(p) for b in pieces) >= 0.6 for p in people)
            assert len(one) == 1 and max(one[0].bbox.iou(p) for p in people) < 0.6
