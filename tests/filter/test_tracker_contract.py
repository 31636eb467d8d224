"""The contract of `tracking.Tracker`, run over every registered tracker (each preset) and the
test-only colour tracker: every frame offers everything any tracker can need (detections, the
colour image, the motion mask, the camera window) of one red square that crosses the view and
then leaves it."""

from __future__ import annotations

import colour_tracker
import numpy as np
import pytest

from tracker_filter.filter_registry import FILTERS
from tracker_filter.layout import StateLayout
from tracker_filter.observation import Detections, Observation
from tracker_filter.trackers import TRACKERS
from tracker_filter.tracking import OutOfOrderError, Tracker, TrackSet, TrackStatus
from tracker_msgs_py.geometry import Rect

DT = 0.1
WIDTH, HEIGHT, SIDE = 160, 120, 10
WINDOW = Rect(0.0, 0.0, float(WIDTH), float(HEIGHT))  # camera px = scene px
# the contract is the bookkeeping, not a size threshold: blob trackers are told the square is big
# enough to start a track, and that it moves 0.6 of its size per frame (their defaults: people)
SIZED_FOR_THE_SQUARE = {
    "occupancy_particles": {"min_area": 50.0, "min_height": 8.0, "jitter_box_factor": 1.5}
}


def builds() -> list[tuple[str, object]]:
    cases: list[tuple[str, object]] = []
    for method in TRACKERS:
        for preset in ("", *method.presets):
            values = method.defaults(preset) | SIZED_FOR_THE_SQUARE.get(method.name, {})
            cases.append((f"{method.name}:{preset or 'defaults'}", (method, values)))
    gated = TRACKERS.get("gated_hungarian")
    for name in FILTERS.names():  # every registered filter inside the gated-Hungarian tracker
        cases.append((f"gated_hungarian:{name}", (gated, gated.defaults() | {"filter": name})))
    cases.append(("red_blob_test", (colour_tracker.METHOD, colour_tracker.METHOD.defaults())))
    return cases


CASES = builds()


def make(case) -> Tracker:
    method, values = case
    return method.build(values, 1)


def frame(k: int, visible: bool = True) -> Observation:
    """Frame k: the square at x = 20 + 6k px, y = 50 px, while visible."""
    image = np.full((HEIGHT, WIDTH, 3), 90, np.uint8)
    mask = np.zeros((HEIGHT, WIDTH), np.uint8)
    detections = Detections.empty()
    if visible:
        x, y = 20 + 6 * k, 50
        image[y : y + SIDE, x : x + SIDE] = (0, 0, 255)
        mask[y : y + SIDE, x : x + SIDE] = 1
        centre = np.array([[x + SIDE / 2, y + SIDE / 2]])
        box = np.array([[x, y, SIDE, SIDE]], dtype=float)
        detections = Detections(centre, [SIDE * SIDE], box, [1.0])
    return Observation(k * DT, detections, visible, image, mask, WINDOW)


def run(tracker: Tracker, frames: list[Observation]) -> list[TrackSet]:
    return [tracker.step(obs) for obs in frames]


SEQUENCE = [frame(k) for k in range(8)] + [frame(k, visible=False) for k in range(8, 30)]


@pytest.mark.parametrize("case", [c for _, c in CASES], ids=[name for name, _ in CASES])
class TestTrackerContract:
    def test_satisfies_the_protocol_and_reports_its_layout(self, case):
        tracker = make(case)
        assert isinstance(tracker, Tracker)
        assert StateLayout.from_names(tracker.layout.text) == tracker.layout  # as Track says it
        for tracks in run(tracker, SEQUENCE):
            assert tracks.layout == tracker.layout
            assert tracks.means.shape == (len(tracks), tracker.layout.dim)
            assert tracks.covariances.shape == (len(tracks),) + (tracker.layout.dim,) * 2
            assert tracks.bboxes.shape == (len(tracks), 4)

    def test_follows_the_square_and_reports_it_lost_exactly_once(self, case):
        history = run(make(case), SEQUENCE)
        confirmed = [
            tracks.positions[i]
            for tracks in history[:8]
            for i in range(len(tracks))
            if tracks.status[i] == TrackStatus.CONFIRMED
        ]
        assert confirmed, "the square was never a confirmed track"
        # within half the square's side: a colour particle filter started at rest, with noise
        # sized for people, trails the 10 px square moving 6 px a frame by up to 4 px
        assert np.allclose(confirmed[-1], [20 + 6 * 7 + SIDE / 2, 50 + SIDE / 2], atol=SIDE / 2)
        lost = [(k, int(i)) for k, t in enumerate(history) for i in t.ids[t.status == 3]]
        ids = {i for t in history for i in t.ids.tolist()}
        assert sorted(i for _, i in lost) == sorted(ids)  # every track ends LOST, once
        for k, track_id in lost:
            assert all(track_id not in t.ids for t in history[k + 1 :])
        assert len(history[-1]) == 0

    def test_out_of_order_steps_are_refused_without_changing_state(self, case):
        tracker, twin = make(case), make(case)
        run(tracker, SEQUENCE[:4])
        run(twin, SEQUENCE[:4])
        for bad in (SEQUENCE[3], SEQUENCE[1], frame(2)):
            with pytest.raises(OutOfOrderError):
                tracker.step(bad)
        with pytest.raises(OutOfOrderError):
            tracker.step(Observation(float("nan")))
        for a, b in zip(run(tracker, SEQUENCE[4:]), run(twin, SEQUENCE[4:]), strict=True):
            assert a.ids.tolist() == b.ids.tolist()
            assert np.array_equal(a.means, b.means) and np.array_equal(a.status, b.status)

    def test_ids_are_not_reused_after_a_reset_unless_asked(self, case):
        tracker = make(case)
        history = run(tracker, SEQUENCE[:4])
        first = {i for t in history for i in t.ids.tolist()}
        assert tracker.reset() == int(np.count_nonzero(history[-1].status != TrackStatus.LOST))
        again = {i for t in run(tracker, SEQUENCE[:4]) for i in t.ids.tolist()}
        assert first and again and not first & again
        tracker.reset(reset_ids=True)
        assert tracker.next_id == 1
        assert {i for t in run(tracker, SEQUENCE[:4]) for i in t.ids.tolist()} == first

    def test_a_needed_input_that_is_lost_is_a_miss_not_an_error(self, case):
        tracker = make(case)
        run(tracker, SEQUENCE[:4])
        blind = Observation(0.4, Detections.empty(), False, None, None, None)
        tracks = tracker.step(blind)
        assert all(s in (TrackStatus.COASTING, TrackStatus.TENTATIVE, 3) for s in tracks.status)
        assert (tracks.misses >= 1).all()
