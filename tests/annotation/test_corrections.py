"""The corrections file: every kind of fix does what the review meant, counts what it changed, and
refuses a fix that names an id or box that is not there."""

from __future__ import annotations

import pytest

from tracker_ptz_sim.annotation import corrections
from tracker_ptz_sim.annotation.corrections import CorrectionError
from tracker_ptz_sim.simulation.ground_truth import Box, Tracks


def track(frames: range, x: float) -> dict[int, Box]:
    return {f: Box(x + f, 10.0, 20.0, 50.0, 0.8) for f in frames}


def two_people() -> Tracks:
    return Tracks({1: track(range(1, 11), 0.0), 2: track(range(1, 11), 100.0)})


def applied(text: str, tracks: Tracks | None = None) -> corrections.Applied:
    return corrections.apply(tracks or two_people(), corrections.parse(text))


def test_delete_a_whole_track_and_a_span():
    out = applied("- delete: {id: 2, why: the sign}\n- delete: {id: 1, frames: [3, 5]}")
    assert out.tracks.ids() == [1]
    assert sorted(out.tracks.by_id[1]) == [1, 2, 6, 7, 8, 9, 10]
    assert out.counts["boxes removed"] == 13 and out.counts["tracks deleted"] == 1


def test_add_keyframes_to_a_new_id_and_move_a_box():
    out = applied(
        "- add: {id: 7, boxes: {4: [1, 2, 30, 60], 2: [0, 0, 30, 60]}}\n"
        "- move: {id: 1, boxes: {5: [50, 60, 25, 55]}}"
    )
    assert list(out.tracks.by_id[7]) == [2, 4]  # kept in frame order
    assert out.tracks.by_id[7][4] == Box(1.0, 2.0, 30.0, 60.0)
    assert out.tracks.by_id[1][5] == Box(50.0, 60.0, 25.0, 55.0)
    assert out.counts["boxes added"] == 2 and out.counts["boxes moved"] == 1


def test_join_split_and_swap_fix_identities():
    tracks = Tracks({1: track(range(1, 6), 0.0), 3: track(range(6, 11), 0.0)})
    joined = applied("- join: {ids: [1, 3]}", tracks)
    assert joined.tracks.ids() == [1] and sorted(joined.tracks.by_id[1]) == list(range(1, 11))

    split = applied("- split: {id: 1, frame: 6, new_id: 9}")
    assert sorted(split.tracks.by_id[1]) == list(range(1, 6))
    assert sorted(split.tracks.by_id[9]) == list(range(6, 11))

    swapped = applied("- swap: {ids: [1, 2], frame: 8}")
    assert swapped.tracks.by_id[1][7].x == 7.0 and swapped.tracks.by_id[1][8].x == 108.0
    assert swapped.tracks.by_id[2][8].x == 8.0
    assert swapped.counts["id fixes"] == 1 and swapped.counts["swap"] == 1


def test_the_input_tracks_are_left_alone():
    tracks = two_people()
    applied("- delete: {id: 1}\n- move: {id: 2, boxes: {1: [0, 0, 5, 5]}}", tracks)
    assert tracks.ids() == [1, 2] and tracks.by_id[2][1].x == 101.0


@pytest.mark.parametrize(
    ("text", "cause"),
    [
        ("- delete: {id: 5}", "there is no id 5"),
        ("- delete: {id: 1, frames: [20, 30]}", "no box in frames 20-30"),
        ("- move: {id: 1, boxes: {40: [0, 0, 5, 5]}}", "no box in frame 40"),
        ("- add: {id: 1, boxes: {3: [0, 0, 5, 5]}}", "already has a box in 3"),
        ("- add: {id: 4, boxes: {3: [0, 0, -5, 5]}}", "w, h > 0"),
        ("- join: {ids: [1, 2]}", "share frames"),
        ("- split: {id: 1, frame: 1, new_id: 5}", "both sides"),
        ("- split: {id: 1, frame: 4, new_id: 2}", "id 2 is taken"),
        ("- rename: {id: 1}", "must be one of"),
        ("- delete: {id: one}", "whole number"),
    ],
)
def test_a_fix_that_does_not_fit_is_refused_with_its_place(text, cause):
    with pytest.raises(CorrectionError, match="fix 1") as error:
        applied(text)
    assert cause in str(error.value)


def test_a_path_is_interpolated_and_snapped_to_the_assistants_boxes():
    from tracker_ptz_sim.simulation.ground_truth import Detections

    detections = Detections(
        {
            3: [Box(21.0, 11.0, 20.0, 50.0, 0.3), Box(200.0, 0.0, 20.0, 50.0, 0.9)],
            4: [Box(60.0, 10.0, 40.0, 100.0, 0.8)],  # twice as tall: two people, never snapped
        }
    )
    text = "- path: {id: 1, boxes: {2: [10, 10, 20, 50], 6: [50, 10, 20, 50]}}"
    out = corrections.apply(two_people(), corrections.parse(text), detections)
    boxes = out.tracks.by_id[1]
    assert boxes[2] == Box(10.0, 10.0, 20.0, 50.0)  # a keyframe as written
    assert boxes[3] == Box(21.0, 11.0, 20.0, 50.0)  # the assistant's box, which overlaps best
    assert boxes[4].x == 30.0 and boxes[4].score == 0.0  # interpolated, nothing to snap to
    assert boxes[7].x == 7.0 and boxes[1].x == 1.0  # outside the span: left alone
    assert out.counts["boxes snapped"] == 1 and out.counts["boxes moved"] == 5
    unsnapped = corrections.apply(
        two_people(), corrections.parse(text.replace("{id: 1,", "{id: 1, snap: false,")), detections
    )
    assert unsnapped.tracks.by_id[1][3].x == 20.0
