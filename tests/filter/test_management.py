"""Track management: ids through gaps and crossings (motmetrics), confirmation, deletion, the
seed's single-target configuration, and bad input."""

import motmetrics as mm
import numpy as np
import pytest

from tracker_filter.filters import PerTrackFactory
from tracker_filter.gated_hungarian.association import Association
from tracker_filter.gated_hungarian.config import TrackerConfig
from tracker_filter.management import BoxGate, MergedSplitter, OverlapRecovery, TrackManager
from tracker_filter.object_scale import HeightByRow
from tracker_filter.observation import Detections, Observation
from tracker_filter.synthetic import bouncing_scene, piecewise_constant_velocity
from tracker_filter.tracking import OutOfOrderError, TrackStatus
from tracker_msgs_py.geometry import Rect

DT = 0.12
FILTERS = ["kalman_cv", "alpha_beta", "kalman_ca", "alpha_beta_gamma"]


def multi(**overrides):
    return TrackerConfig.preset("multi", **overrides).build_tracker()


def test_statuses_match_the_message_constants():
    track = pytest.importorskip("tracker_msgs.msg").Track
    for status in TrackStatus:
        assert getattr(track, f"STATUS_{status.name}") == status.value


def count_id_switches(frames, tracker, gate=25.0):
    """Run the tracker and let motmetrics count identity switches against the truth."""
    accumulator = mm.MOTAccumulator(auto_id=True)
    for truth_ids, truth_positions, detections, t in frames:
        tracks = tracker.step(Observation(t, detections))
        shown = (tracks.status == TrackStatus.CONFIRMED) | (tracks.status == TrackStatus.COASTING)
        distances = mm.distances.norm2squared_matrix(
            truth_positions, tracks.positions[shown], max_d2=gate**2
        )
        accumulator.update(truth_ids, tracks.ids[shown], distances)
    summary = mm.metrics.create().compute(
        accumulator, metrics=["num_switches", "num_misses", "num_false_positives"]
    )
    return summary.iloc[0]


@pytest.mark.parametrize("kind", FILTERS)
def test_two_crossing_targets_keep_their_ids(kind):
    rng = np.random.default_rng(0)
    a = piecewise_constant_velocity((100.0, 100.0), [(6.0, (60.0, 40.0))], DT)
    b = piecewise_constant_velocity(
        (100.0, 340.0), [(6.0, (60.0, -40.0))], DT
    )  # crosses a at t = 3 s
    frames = []
    for k, t in enumerate(a.times):
        truth = np.array([a.positions[k], b.positions[k]])
        frames.append(
            (
                [1, 2],
                truth,
                Detections.from_positions(truth + rng.normal(scale=1.5, size=(2, 2)), size=20),
                t,
            )
        )
    result = count_id_switches(frames, multi(filter=kind))
    assert result["num_switches"] == 0
    assert result["num_false_positives"] == 0
    assert result["num_misses"] <= 2 * 3  # only while tentative (M = 3)


@pytest.mark.parametrize("kind", FILTERS)
def test_coasting_through_a_10_frame_gap_keeps_the_id(kind):
    trajectory = piecewise_constant_velocity((50.0, 200.0), [(6.0, (50.0, 10.0))], DT)
    z = trajectory.measurements(1.0, np.random.default_rng(1))
    tracker = multi(filter=kind, max_misses=12)
    ids, statuses = set(), []
    for k, t in enumerate(trajectory.times):
        detections = (
            Detections.empty() if 20 <= k < 30 else Detections.from_positions(z[k : k + 1], size=10)
        )
        tracks = tracker.step(Observation(t, detections))
        assert len(tracks) == 1
        ids.add(int(tracks.ids[0]))
        statuses.append(TrackStatus(int(tracks.status[0])))
        if 20 <= k < 30:
            assert tracks.misses[0] == k - 19
            predicted_error = np.linalg.norm(tracks.positions[0] - trajectory.positions[k])
            assert predicted_error < 6.0 + 1.0 * (k - 19)  # coasting at the estimated velocity
    assert ids == {1}
    assert statuses[19] == TrackStatus.CONFIRMED and statuses[25] == TrackStatus.COASTING
    assert statuses[30] == TrackStatus.CONFIRMED


def test_a_target_that_leaves_is_deleted_after_max_misses():
    tracker = multi(max_misses=5)
    trajectory = piecewise_constant_velocity((50.0, 50.0), [(1.2, (40.0, 0.0))], DT)
    for t, z in zip(trajectory.times, trajectory.positions, strict=True):
        tracks = tracker.step(Observation(t, Detections.from_positions(z[None], size=10)))
    assert tracks.status[0] == TrackStatus.CONFIRMED
    t = trajectory.times[-1]
    history = []
    for k in range(1, 8):
        tracks = tracker.step(Observation(t + k * DT, Detections.empty()))
        history.append(
            [(int(i), TrackStatus(int(s))) for i, s in zip(tracks.ids, tracks.status, strict=True)]
        )
    assert history[:4] == [[(1, TrackStatus.COASTING)]] * 4
    assert history[4] == [(1, TrackStatus.LOST)]  # reported once, at the 5th miss
    assert history[5:] == [[], []]
    assert len(tracker) == 0


def test_m_of_n_confirmation_and_clutter():
    tracker = multi(confirm_hits=3, confirm_window=5)
    z = np.array([[100.0, 100.0]])
    pattern = [True, False, True, False, True]  # 3 hits in 5 frames: confirmed on the 5th
    for k, hit in enumerate(pattern):
        tracks = tracker.step(
            Observation(
                k * DT,
                Detections.from_positions(z + [5.0 * k, 0.0], size=10)
                if hit
                else Detections.empty(),
            )
        )
    assert tracks.status.tolist() == [TrackStatus.CONFIRMED]
    failing = multi(confirm_hits=3, confirm_window=4)
    for k, hit in enumerate([True, False, False]):
        tracks = failing.step(
            Observation(
                k * DT, Detections.from_positions(z, size=10) if hit else Detections.empty()
            )
        )
    assert tracks.status.tolist() == [TrackStatus.LOST]  # 1 hit + 1 frame left < 3: given up early
    # one-frame clutter anywhere never confirms
    rng = np.random.default_rng(2)
    clutter_tracker = multi()
    for k in range(40):
        tracks = clutter_tracker.step(
            Observation(
                k * DT, Detections.from_positions(rng.uniform(0, 2000, size=(5, 2)), size=10)
            )
        )
        assert not np.any(tracks.status == TrackStatus.CONFIRMED)


def _statuses(tracker, xs):
    """Step a tracker with one detection per frame at (x, 100) for x in xs; every TrackSet."""
    return [
        tracker.step(
            Observation(k * DT, Detections.from_positions(np.array([[x, 100.0]]), size=10))
        )
        for k, x in enumerate(xs)
    ]


def test_only_consistent_movers_are_confirmed():
    rules = {"confirm_travel": 12.0, "confirm_straightness": 0.7}
    walker = _statuses(multi(**rules), [100.0 + 4.0 * k for k in range(20)])
    assert walker[3].status.tolist() == [TrackStatus.CONFIRMED]  # 12 px in 3 frames, straight
    assert walker[-1].straightness[0] == pytest.approx(1.0)
    # A swaying thing (8 px to and fro, period 8 frames) drifting 0.8 px a frame: 23 px from where
    # it began after 40 frames, along a path six times longer.
    sway = [100.0 + 0.8 * k + 8.0 * np.sin(2 * np.pi * k / 8) for k in range(40)]
    tracks = _statuses(multi(**rules), sway)
    assert not any(np.any(t.status == TrackStatus.CONFIRMED) for t in tracks)
    assert tracks[-1].ids.tolist() == [1]  # one track all along, kept tentative
    assert tracks[-1].travel[0] > 12.0 and tracks[-1].straightness[0] < 0.2
    # Without the straightness rule the same sway is taken for a mover.
    lenient = _statuses(multi(confirm_travel=12.0), sway)
    assert lenient[-1].status.tolist() == [TrackStatus.CONFIRMED]
    # A thing that stays put is dropped when the travel window ends, never confirmed.
    still = _statuses(multi(**rules, confirm_travel_window=10), [100.0] * 12)
    assert [t.status.tolist() for t in still[8:10]] == [[0], [TrackStatus.LOST]]  # 10th frame
    assert not any(np.any(t.status == TrackStatus.CONFIRMED) for t in still)


def _track_points(tracker, points):
    """Step a tracker with one detection (10 px box) per frame at each (x, y); every TrackSet."""
    return [
        tracker.step(Observation(k * 0.1, Detections.from_positions(np.array([p]), size=10)))
        for k, p in enumerate(points)
    ]


def test_a_slow_walker_whose_centroid_jitters_is_confirmed_with_a_straightness_step():
    """A walker at 2.5 px a frame whose blob centroid jitters by 2.5 px (limbs come and go):
    frame to frame, the path is twice the way and straightness stays below 0.7; measured between
    waypoints 6 px apart it is a walker's. A sway in place is still no mover."""
    rng = np.random.default_rng(5)
    walk = [(100 + 2.5 * k + rng.normal(0, 2.5), 100 + rng.normal(0, 2.5)) for k in range(30)]
    rules = {"confirm_travel": 12.0, "confirm_straightness": 0.7, "measurement_noise": 6.0}

    def confirmed(tracksets):
        return [k for k, t in enumerate(tracksets) if np.any(t.status == TrackStatus.CONFIRMED)]

    frame_to_frame = _track_points(multi(**rules), walk)
    assert confirmed(frame_to_frame) == [] and frame_to_frame[-1].ids.tolist() == [1]
    assert frame_to_frame[-1].straightness[0] < 0.6
    stepped = _track_points(multi(**rules, straightness_step=6.0), walk)
    assert confirmed(stepped)[0] <= 6
    assert stepped[-1].straightness[0] > 0.7
    sway = [(100.0 + 0.8 * k + 8.0 * np.sin(2 * np.pi * k / 8), 100.0) for k in range(40)]
    assert confirmed(_track_points(multi(**rules, straightness_step=6.0), sway)) == []


def _person(x: float, legs: bool = True) -> np.ndarray:
    """A person's box (24 x 50 at (x, 100)), or its upper half when the legs are not found."""
    return np.array([x, 100.0, 24.0, 50.0 if legs else 25.0])


def _boxes(boxes: list[np.ndarray]) -> Detections:
    box = np.array(boxes)
    return Detections(box[:, :2] + box[:, 2:] / 2, box[:, 2] * box[:, 3], box, np.zeros(len(box)))


def test_a_track_keeps_a_detection_whose_centroid_jumped_when_their_boxes_overlap():
    """A walker's blob loses its legs for three frames: its centroid jumps 12.5 px up, beyond
    the centroid gate (R = 2 px). Paired by box overlap, the track goes on under its id;
    without, a new track starts and the walker's own coasts."""

    def ids(recover_overlap: float) -> set[int]:
        tracker = multi(recover_overlap=recover_overlap)
        seen: set[int] = set()
        for k in range(30):
            box = _person(40.0 + 4.0 * k, legs=not 15 <= k < 18)
            tracks = tracker.step(Observation(k * 0.1, _boxes([box])))
            seen |= set(tracks.ids[tracks.status != TrackStatus.LOST].tolist())
        return seen

    assert ids(0.3) == {1}
    assert len(ids(0.0)) > 1
    recovery = OverlapRecovery(0.3)
    none = Association(np.zeros(0, np.int64), np.zeros(0, np.int64))
    track_boxes = np.array([_person(100.0), _person(300.0)])
    found = np.array([_person(330.0), _person(104.0, False)])
    paired = recovery.recover(none, track_boxes, found, np.array([True, True]))
    assert paired.tracks.tolist() == [0] and paired.measurements.tolist() == [1]
    assert len(recovery.recover(none, track_boxes, found, np.array([False, True])).tracks) == 0


def test_box_edges_that_jump_are_kept_until_the_change_persists():
    """A walker's box loses its legs for 3 frames and a flickering sign joins it from above for
    2 (both paired by box overlap): the track's box keeps the walker's height (IoU with the
    walker >= 0.9 throughout). A change that lasts (a person who sits down: half the height from
    frame 20 on) is taken after `patience` frames."""
    tracker = multi(box_tolerance=0.2, recover_overlap=0.3)
    for k in range(40):
        box = _person(40.0 + 4.0 * k, legs=not 10 <= k < 13)
        if 15 <= k < 17:  # a 24 x 40 sign 10 px above the head joins the blob
            box = np.array([box[0], 50.0, 24.0, 100.0])
        if k >= 20:
            box = np.array([box[0], 125.0, 24.0, 25.0])
        tracks = tracker.step(Observation(k * 0.1, _boxes([box])))
        (x, y, w, h), expected = tracks.bboxes[0], _person(40.0 + 4.0 * k)
        if 5 <= k < 20:
            assert Rect(x, y, w, h).iou(Rect(*expected)) >= 0.9, k
        if k >= 20 + BoxGate().patience:
            assert (y, h) == pytest.approx((125.0, 25.0), abs=1.0)
    assert tracks.ids.tolist() == [1]


def test_the_learned_height_says_which_box_edge_to_believe():
    """People here are half as tall as the row of their feet (learned from ten boxes). A track
    whose box held a sign above the person (100 px tall at row 150, where people are 75) takes
    the person's 75 px box at once; a track on the person keeps its top edge when the sign joins
    the detection. Without the learned height both jumps are held; before the line is learned,
    nothing is."""
    scale = HeightByRow(0.5, min_samples=10)
    rows = np.linspace(100.0, 300.0, 10)
    scale.observe(np.column_stack([np.zeros(10), rows / 2, np.full(10, 20.0), rows / 2]))
    person, merged = np.array([100.0, 75.0, 24.0, 75.0]), np.array([100.0, 50.0, 24.0, 100.0])

    def gated(gate: BoxGate, predicted: np.ndarray, found: np.ndarray) -> np.ndarray:
        one = np.array([0])
        strikes = np.zeros((1, 4), np.int64)
        result: np.ndarray = gate.gate(_boxes([found]), one, one, predicted[None], strikes).bboxes[
            0
        ]
        return result

    informed, blind = BoxGate(0.2, scale=scale), BoxGate(0.2)
    assert gated(informed, merged, person) == pytest.approx(person)
    assert gated(informed, person, merged) == pytest.approx(person)
    assert gated(blind, merged, person) == pytest.approx(merged)
    assert gated(blind, person, merged) == pytest.approx(person)
    unlearned = BoxGate(0.2, scale=HeightByRow(0.5, min_samples=10))  # nothing held yet
    assert gated(unlearned, person, merged) == pytest.approx(merged)


def test_many_targets_with_clutter_keep_their_ids():
    # paths that stay clear of the borders: a bounce reverses a target within one frame, which a
    # constant-velocity gate cannot follow (the track is lost and restarted under a new id)
    scene = bouncing_scene(
        np.random.default_rng(3),
        targets=20,
        clutter=10,
        frames=40,
        speed=(20.0, 50.0),
        start_region=(0.25, 0.75),
    )
    frames = [(f.truth_ids, f.truth_positions, f.detections, f.time) for f in scene]
    result = count_id_switches(frames, multi())
    assert result["num_switches"] == 0
    assert result["num_misses"] <= 20 * 3
    assert result["num_false_positives"] <= 2  # clutter rarely gets 3 hits in 4 frames


def test_seed_single_target_mode():
    config = TrackerConfig.preset("seed000")
    tracker = config.build_tracker()
    small, large = [300.0, 100.0], [100.0, 100.0]
    frames = []
    for k in range(6):  # two blobs: only the largest is a measurement, tracked from its first hit
        frames.append(
            Detections(
                np.array([small, [large[0] + 5 * k, large[1]]]),
                [50, 400],
                [[0, 0, 5, 10], [0, 0, 20, 20]],
                [0.3, 0.2],
            )
        )
    for k, detections in enumerate(frames):
        tracks = tracker.step(Observation(k * DT, detections))
        assert len(tracks) == 1 and tracks.status[0] == TrackStatus.CONFIRMED and tracks.ids[0] == 1
        assert tracks.detections[0] == 0  # index among the selected detections
    assert abs(tracks.positions[0, 0] - 125.0) < 3.0
    t = 5 * DT
    for k in range(1, 5):  # search -> track -> reset after 4 consecutive misses
        tracks = tracker.step(Observation(t + k * DT, Detections.empty()))
        expected = TrackStatus.LOST if k == 4 else TrackStatus.COASTING
        assert tracks.status.tolist() == [expected]
    tracks = tracker.step(
        Observation(t + 5 * DT, Detections.from_positions([[400.0, 200.0]], size=10))
    )
    assert tracks.ids.tolist() == [2] and tracks.status[0] == TrackStatus.CONFIRMED
    # no gate: even a far jump of the single blob updates the one track
    tracks = tracker.step(
        Observation(t + 6 * DT, Detections.from_positions([[10.0, 10.0]], size=10))
    )
    assert tracks.ids.tolist() == [2] and tracks.hits[0] == 2


def test_bad_input_leaves_the_state_untouched():
    tracker = multi()
    tracker.step(Observation(1.0, Detections.from_positions([[10.0, 10.0]], size=4)))
    tracks = tracker.step(
        Observation(
            1.1, Detections.from_positions([[np.nan, 10.0], [11.0, 10.0], [np.inf, 0.0]], size=4)
        )
    )
    assert tracks.rejected_measurements == 2 and tracker.rejected_measurements == 2
    assert len(tracks) == 1 and tracks.hits[0] == 2
    means = tracker.bank.means.copy()
    for bad_time in (1.1, 0.5, float("nan")):
        with pytest.raises(OutOfOrderError):
            tracker.step(Observation(bad_time, Detections.from_positions([[12.0, 10.0]], size=4)))
    np.testing.assert_array_equal(tracker.bank.means, means)
    assert tracker.time == 1.1
    with pytest.raises(ValueError, match="positions"):
        Detections(np.zeros((2, 2)), np.zeros(3), np.zeros((2, 4)), np.zeros(2))


def test_detections_that_cannot_be_measurements_are_rejected_by_cause():
    good = [50.0, 60.0, 10.0, 10.0, 100.0, 0.3]  # x, y, box w, box h, area, score
    rows = [
        good,
        [1e308, 60.0, 10.0, 10.0, 100.0, 0.3],  # centroid far outside any scene
        [50.0, 60.0, 10.0, 10.0, 100.0, np.nan],  # NaN score
        [50.0, 60.0, -10.0, 10.0, 100.0, 0.3],  # negative box width
        [50.0, np.inf, -10.0, 10.0, 100.0, np.nan],  # several problems: counted under the first
        [50.0, 60.0, 10.0, 10.0, -1.0, 0.3],  # negative area
    ]
    values = np.array(rows)
    boxes = np.column_stack([values[:, :2] - 5.0, values[:, 2:4]])
    detections = Detections(values[:, :2], values[:, 4], boxes, values[:, 5])
    valid, rejected = detections.validated()
    assert len(valid) == 1 and valid.positions.tolist() == [[50.0, 60.0]]
    assert rejected == {
        "non-finite centroid": 1,
        "centroid beyond 1e+06 px": 1,
        "negative box size": 1,
        "non-finite or negative area": 1,
        "score not finite or beyond 1e+06": 1,
    }
    tracker = multi()
    tracks = tracker.step(Observation(1.0, detections))
    assert len(tracks) == 1 and tracks.rejections == rejected
    assert np.isfinite(tracks.means).all() and (tracks.bboxes[:, 2:] >= 0).all()


def test_each_fault_alone_is_rejected_under_its_cause():
    """One faulty detection among good ones, for every cause: the check of a whole frame at once
    (the usual, all-valid case) must not let any of them through."""
    good = ([50.0, 60.0], [45.0, 55.0, 10.0, 10.0], 100.0, 0.3)  # centroid, box, area, score
    faults = {
        "non-finite centroid": ([np.nan, 60.0], good[1], 100.0, 0.3),
        "centroid beyond 1e+06 px": ([-2e6, 60.0], good[1], 100.0, 0.3),
        "non-finite box": (good[0], [45.0, np.inf, 10.0, 10.0], 100.0, 0.3),
        "box beyond 1e+06 px": (good[0], [45.0, 55.0, 3e6, 10.0], 100.0, 0.3),
        "negative box size": (good[0], [45.0, 55.0, 10.0, -0.5], 100.0, 0.3),
        "non-finite or negative area": (good[0], good[1], np.inf, 0.3),
        "score not finite or beyond 1e+06": (good[0], good[1], 100.0, -np.inf),
    }
    for cause, fault in faults.items():
        rows = [good, fault, good]
        detections = Detections(
            np.array([r[0] for r in rows]),
            np.array([r[2] for r in rows]),
            np.array([r[1] for r in rows]),
            np.array([r[3] for r in rows]),
        )
        valid, rejected = detections.validated()
        assert rejected == {cause: 1} and len(valid) == 2, cause
    assert set(faults) == set(detections.invalid_by_cause())


def test_reset_and_ids():
    tracker = multi()
    tracker.step(Observation(5.0, Detections.from_positions([[10.0, 10.0], [50.0, 50.0]], size=4)))
    assert tracker.reset() == 2 and len(tracker) == 0 and tracker.time is None
    tracks = tracker.step(
        Observation(1.0, Detections.from_positions([[10.0, 10.0]], size=4))
    )  # earlier stamp accepted
    assert tracks.ids.tolist() == [3]
    tracker.reset(reset_ids=True)
    assert tracker.step(
        Observation(2.0, Detections.from_positions([[10.0, 10.0]], size=4))
    ).ids.tolist() == [1]


def test_report_fields_and_boxes_follow_coasting_tracks():
    tracker = multi(confirm_hits=1, confirm_window=1)
    for k in range(5):
        detections = Detections(
            np.array([[100.0 + 10 * k, 50.0]]), [300.0], [[90.0 + 10 * k, 40.0, 20.0, 20.0]], [0.1]
        )
        tracks = tracker.step(Observation(k * 0.1, detections))
    report = next(iter(tracks))
    assert report.bbox == (130.0, 40.0, 20.0, 20.0) and report.area == 300.0
    assert report.age == pytest.approx(0.4) and report.hits == 5 and report.existence == 1.0
    np.testing.assert_allclose(report.position_covariance, report.covariance[:2, :2])
    coasting = tracker.step(Observation(0.5, Detections.empty())).report(0)
    shift = coasting.position - report.position
    assert coasting.bbox[:2] == pytest.approx((130.0 + shift[0], 40.0 + shift[1]))
    assert coasting.status == TrackStatus.COASTING and coasting.detection == -1
    np.testing.assert_allclose(
        tracks.predicted_positions(0.5)[0], report.position + 0.5 * report.velocity
    )


def test_object_bank_plugs_in_and_gives_the_same_tracks():
    config = TrackerConfig.preset("multi")
    components = config.build_tracker()
    fast = config.build_tracker()
    plug = TrackManager(
        PerTrackFactory(config.filter),
        components.associator,
        components.initiator,
        components.confirmation,
        components.deleter,
    )
    for frame in bouncing_scene(np.random.default_rng(4), targets=6, clutter=3, frames=25):
        a, b = (
            fast.step(Observation(frame.time, frame.detections)),
            plug.step(Observation(frame.time, frame.detections)),
        )
        np.testing.assert_array_equal(a.ids, b.ids)
        np.testing.assert_array_equal(a.status, b.status)
        np.testing.assert_allclose(a.means, b.means, rtol=1e-9, atol=1e-8)


def test_a_detection_holding_two_tracked_objects_is_split_between_them():
    splitter = MergedSplitter(min_growth=1.25)
    merged = Detections(
        np.array([[130.0, 125.0]]),
        np.array([4000.0]),
        np.array([[100.0, 100.0, 60.0, 52.0]]),
        [0.3],
    )
    boxes = np.array([[96.0, 100.0, 24.0, 50.0], [134.0, 101.0, 26.0, 50.0]])  # left, right
    positions = boxes[:, :2] + boxes[:, 2:] / 2
    pieces = splitter.split(merged, boxes, positions, np.array([True, True]))
    assert len(pieces) == 2
    left, right = pieces.bboxes
    assert list(left) == [100.0, 100.0, 24.0, 50.0]  # pushed 4 px inside the detection
    assert list(right) == [134.0, 101.0, 26.0, 50.0]
    assert pieces.positions[0] == pytest.approx(positions[0] + [4.0, 0.0])
    assert pieces.areas.sum() == pytest.approx(4000.0)
    # a tentative track, a head track inside a body track, a detection no bigger than one object:
    # the detection is one object's
    assert splitter.split(merged, boxes, positions, np.array([True, False])) is merged
    nested = np.array([[100.0, 100.0, 60.0, 52.0], [120.0, 100.0, 20.0, 20.0]])
    assert splitter.split(merged, nested, positions, np.array([True, True])) is merged
    assert MergedSplitter(min_growth=3.0).split(merged, boxes, positions, np.array([True] * 2)) is (
        merged
    )


def test_people_walking_past_each_other_keep_their_tracks_while_one_blob():
    """Two people (24 x 50) walk towards each other, pass and walk on; while their boxes overlap
    the detector sees one blob. Split by the predicted tracks, both stay observed with their own
    ids as the blob forms (once one hides the other by half, nothing tells two people from two
    tracks on one, and one coasts), and both come out of it with their ids."""

    def run(split_merged: float) -> tuple[list[int], dict[int, float]]:
        tracker = multi(split_merged=split_merged, filter="kalman_cv")
        observed_while_forming = []
        for k in range(40):
            t = k * 0.1
            a = np.array([40.0 + 40.0 * t, 100.0, 24.0, 50.0])  # walks right
            b = np.array([240.0 - 40.0 * t, 104.0, 24.0, 50.0])  # walks left
            if abs(a[0] - b[0]) < 24.0:
                x0, y0 = min(a[0], b[0]), min(a[1], b[1])
                x1, y1 = max(a[0], b[0]) + 24.0, max(a[1], b[1]) + 50.0
                box = np.array([[x0, y0, x1 - x0, y1 - y0]])
            else:
                box = np.array([a, b])
            centres = box[:, :2] + box[:, 2:] / 2
            tracks = tracker.step(
                Observation(t, Detections(centres, box[:, 2] * box[:, 3], box, np.zeros(len(box))))
            )
            observed = tracks.status == TrackStatus.CONFIRMED
            if len(box) == 1 and a[0] < b[0] and box[0, 2] >= 1.5 * 24.0:
                observed_while_forming.append(int(observed.sum()))
        return observed_while_forming, dict(
            zip(tracks.ids.tolist(), tracks.bboxes[:, 0], strict=True)
        )

    forming, last_x = run(1.25)
    assert forming == [2]
    assert last_x == pytest.approx({1: 40.0 + 40.0 * 3.9, 2: 240.0 - 40.0 * 3.9})
    forming, _ = run(0.0)
    assert forming == [1]
