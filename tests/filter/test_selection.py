"""Target selection: the policies, hysteresis, and the manual modes of the select_target service."""

import dataclasses

import numpy as np
import pytest
from track_sets import C, K, L, T, track_set

from tracker_filter.selection import SelectionPolicy, TargetSelector
from tracker_msgs_py.geometry import Rect


def test_policies_match_the_message_constants():
    target = pytest.importorskip("tracker_msgs.msg").Target
    for policy in SelectionPolicy:
        assert getattr(target, f"SELECT_{policy.name}") == policy.value


def test_each_automatic_policy_picks_its_best_confirmed_track():
    tracks = track_set(
        5.0,
        [1, 2, 3, 4],
        [[0, 0], [100, 0], [40, 40], [50, 50]],
        status=[C, K, C, T],
        ages=[3, 9, 1, 20],
        areas=[50, 80, 900, 999],
    )
    assert (
        TargetSelector(SelectionPolicy.LARGEST_BLOB).update(tracks).track_id == 3
    )  # 4 is tentative
    assert TargetSelector(SelectionPolicy.LONGEST_LIVED).update(tracks).track_id == 2
    nearest = TargetSelector(SelectionPolicy.NEAREST_CENTRE).update(tracks, view_centre=(95.0, 5.0))
    assert nearest.track_id == 2 and nearest.mode == SelectionPolicy.NEAREST_CENTRE
    assert (
        TargetSelector(SelectionPolicy.NEAREST_CENTRE).update(tracks).track_id == 2
    )  # no centre: oldest
    assert TargetSelector().update(track_set(5.0, [7], [[0, 0]], status=[T])) is None


def test_farthest_travelled_prefers_a_walker_to_a_long_lived_flutter():
    # Track 1 has fluttered in place for 60 s; track 2 has walked 80 px in 4 s.
    tracks = track_set(60.0, [1, 2], [[10, 10], [200, 50]], ages=[60, 4], travel=[6, 80])
    assert TargetSelector(SelectionPolicy.LONGEST_LIVED).update(tracks).track_id == 1
    assert TargetSelector(SelectionPolicy.FARTHEST_TRAVELLED).update(tracks).track_id == 2


def test_hysteresis_keeps_the_target_for_the_minimum_lock_time_then_needs_a_margin():
    selector = TargetSelector(SelectionPolicy.LARGEST_BLOB, min_lock_time=2.0, switch_margin=0.2)
    positions = [[0, 0], [100, 100]]
    assert selector.update(track_set(0.0, [1, 2], positions, areas=[100, 50])).track_id == 1
    # a bigger blob appears, but the lock is younger than 2 s
    for t in (0.5, 1.0, 1.9):
        assert selector.update(track_set(t, [1, 2], positions, areas=[100, 300])).track_id == 1
    # after 2 s: 110 is not 20 % better than 100, 300 is
    assert selector.update(track_set(2.1, [1, 2], positions, areas=[100, 110])).track_id == 1
    switched = selector.update(track_set(2.2, [1, 2], positions, areas=[100, 300]))
    assert switched.track_id == 2 and switched.since == 2.2
    # losing the target re-selects at once, whatever the lock time
    assert (
        selector.update(track_set(2.3, [1, 2], positions, status=[C, L], areas=[100, 300])).track_id
        == 1
    )


def test_a_large_margin_keeps_a_target_whose_score_came_out_near_zero():
    """`switch_margin` 1000 keeps the followed person until they are lost, also when their
    travel x straightness is about 0 (a track that went back and forth): the margin is relative
    to at least one unit of the score, not to a vanishing one."""
    selector = TargetSelector(SelectionPolicy.FARTHEST_TRAVELLED, switch_margin=1000.0)
    positions = [[0, 0], [100, 100]]
    assert selector.update(track_set(0.0, [1, 2], positions, travel=[50, 5])).track_id == 1
    kept = selector.update(track_set(5.0, [1, 2], positions, travel=[0.1, 124]))
    assert kept.track_id == 1
    small = TargetSelector(SelectionPolicy.FARTHEST_TRAVELLED, switch_margin=0.2)
    assert small.update(track_set(0.0, [1, 2], positions, travel=[50, 5])).track_id == 1
    assert small.update(track_set(5.0, [1, 2], positions, travel=[0.1, 124])).track_id == 2


def test_manual_id_until_the_track_is_lost():
    selector = TargetSelector(SelectionPolicy.LONGEST_LIVED, min_lock_time=10.0)
    tracks = track_set(1.0, [1, 2], [[0, 0], [50, 50]], ages=[5, 1])
    assert selector.update(tracks).track_id == 1
    assert not selector.select_id(9).success
    assert selector.select_id(2).success  # a live track can be chosen despite the lock
    assert selector.mode == SelectionPolicy.MANUAL_ID
    assert selector.update(track_set(1.1, [1, 2], [[0, 0], [50, 50]], ages=[5, 1])).track_id == 2
    after = selector.update(track_set(1.2, [1, 2], [[0, 0], [50, 50]], status=[C, L], ages=[5, 1]))
    assert after.track_id == 1 and after.mode == SelectionPolicy.LONGEST_LIVED
    assert selector.mode == SelectionPolicy.LONGEST_LIVED


def test_manual_rectangle_takes_the_overlapping_track_or_the_next_one_started_inside():
    selector = TargetSelector(SelectionPolicy.LONGEST_LIVED)
    selector.update(track_set(1.0, [1, 2], [[0, 0], [100, 100]], ages=[5, 1]))
    result = selector.select_rectangle(Rect(90, 90, 30, 30))
    assert result.success and result.track_id == 2
    assert (
        selector.update(track_set(1.1, [1, 2], [[0, 0], [101, 100]])).mode
        == SelectionPolicy.MANUAL_RECT
    )
    pending = selector.select_rectangle(Rect(300, 300, 50, 50))
    assert pending.success and pending.track_id is None and "waiting" in pending.message
    # nothing inside yet: unlocked; an old track walking in does not count, a new one started inside does
    assert selector.update(track_set(1.2, [1, 2], [[0, 0], [310, 310]])) is None
    chosen = selector.update(
        track_set(1.3, [1, 2, 3], [[0, 0], [310, 310], [320, 330]], status=[C, C, T])
    )
    assert chosen.track_id == 3 and chosen.mode == SelectionPolicy.MANUAL_RECT
    assert not selector.select_rectangle(Rect(0, 0, 0, 10)).success


def test_auto_request_and_configuration():
    selector = TargetSelector(SelectionPolicy.LONGEST_LIVED)
    tracks = track_set(1.0, [1, 2], [[0, 0], [50, 50]], ages=[5, 1])
    selector.update(tracks)
    selector.select_id(2)
    result = selector.select_auto()
    assert (
        result.success and result.track_id == 1 and selector.mode == SelectionPolicy.LONGEST_LIVED
    )
    with pytest.raises(ValueError, match="service"):
        selector.configure(SelectionPolicy.MANUAL_ID, 1.0, 0.2)
    with pytest.raises(ValueError, match="min_lock_time"):
        selector.configure(SelectionPolicy.LONGEST_LIVED, -1.0, 0.2)


def test_a_target_coasting_too_long_is_let_go():
    coasting = track_set(5.0, [1, 2], [[0, 0], [50, 0]], status=[K, C], ages=[9, 1])
    coasting = dataclasses.replace(coasting, misses=np.array([3, 0]))
    assert TargetSelector(SelectionPolicy.LONGEST_LIVED).update(coasting).track_id == 1
    strict = TargetSelector(SelectionPolicy.LONGEST_LIVED, max_misses=2)
    assert strict.update(coasting).track_id == 2  # its prediction has strayed: follow the other
    alone = track_set(5.0, [1], [[0, 0]], status=[K])
    assert strict.update(dataclasses.replace(alone, misses=np.array([3]))) is None


def _walking(time, ids, positions, misses, velocity=(20.0, 0.0), status=None):
    tracks = track_set(time, ids, positions, status=status, ages=[9.0] * len(ids), box=40.0)
    means = tracks.means.copy()
    means[:, 2:] = velocity
    return dataclasses.replace(tracks, means=means, misses=np.asarray(misses))


def test_a_hidden_target_is_waited_for_not_swapped_for_the_person_beside_it():
    """A walker (track 1) passes behind the one beside them (track 2) for 0.5 s: without a
    reacquire time the camera moves on to track 2 at once and stays there; with one it holds
    (no target) and takes track 1 back when it is seen again."""

    def frames():
        for k in range(20):
            t = 5.0 + 0.1 * k
            hidden = 3 <= k < 8
            yield _walking(
                t,
                [1, 2],
                [[100 + 2 * k, 50], [110 + 2 * k, 50]],
                [k - 2 if hidden else 0, 0],
                status=[K if hidden else C, C],
            )

    at_once = TargetSelector(SelectionPolicy.LONGEST_LIVED, max_misses=2)
    waiting = TargetSelector(SelectionPolicy.LONGEST_LIVED, max_misses=2, reacquire_time=2.0)
    followed_at_once = [getattr(at_once.update(f), "track_id", None) for f in frames()]
    followed_waiting = [getattr(waiting.update(f), "track_id", None) for f in frames()]
    assert followed_at_once[:5] == [1] * 5 and set(followed_at_once[5:]) == {2}
    assert followed_waiting[:5] == [1] * 5
    assert followed_waiting[5:8] == [None] * 3  # coasting past max_misses: the camera scans
    assert followed_waiting[8:] == [1] * 12
    assert waiting.selection is not None and waiting.selection.since == 5.0  # one lock


def test_a_lost_target_is_taken_up_by_a_new_track_where_it_was_heading():
    selector = TargetSelector(SelectionPolicy.LONGEST_LIVED, reacquire_time=2.0)
    assert selector.update(_walking(1.0, [1, 2], [[100, 50], [300, 50]], [0, 0])).track_id == 1
    # track 1 deleted; 0.5 s later a new track 3 starts 10 px ahead of where 1 was heading
    assert selector.update(_walking(1.1, [2], [[300, 50]], [0])) is None
    later = _walking(1.6, [2, 3], [[300, 50], [120, 50]], [0, 0])
    assert selector.update(later).track_id == 3
    # a new track far from where the lost one was heading is not them: wait, then move on
    selector = TargetSelector(SelectionPolicy.LONGEST_LIVED, reacquire_time=2.0)
    selector.update(_walking(1.0, [1, 2], [[100, 50], [300, 50]], [0, 0]))
    assert selector.update(_walking(1.1, [2, 3], [[300, 50], [200, 50]], [0, 0])) is None
    assert selector.update(_walking(2.9, [2, 3], [[300, 50], [200, 50]], [0, 0])) is None
    assert selector.update(_walking(3.1, [2, 3], [[300, 50], [200, 50]], [0, 0])).track_id == 2


def test_reacquire_time_is_validated():
    with pytest.raises(ValueError, match="reacquire_time"):
        TargetSelector(reacquire_time=-1.0)
