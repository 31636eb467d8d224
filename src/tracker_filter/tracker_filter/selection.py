"""Choosing the one track the pan-tilt camera follows, with hysteresis (no rclpy).

Policies match tracker_msgs/Target SELECT_*. Automatic ones score the confirmed tracks (CONFIRMED or
COASTING) of the labels the selector follows (`labels`: e.g. only "person", so the camera never
follows a flag, a tree or a car unless asked; "any" = every label) every frame:

- LARGEST_BLOB (seed 000): area of the track's last associated detection;
- LONGEST_LIVED: track age;
- NEAREST_CENTRE: minus the distance to the camera view centre (PtzState.window's centre);
  without a known view centre it falls back to LONGEST_LIVED;
- FARTHEST_TRAVELLED: distance from where the track started, times how directly it got there
  (`TrackSet.straightness`), so a person walking through wins over a thing that flutters, sways or
  flickers in place however long it lives and however far its blob wanders.

Hysteresis: once locked, the selector keeps its track for at least `min_lock_time` seconds (scene
time) and afterwards switches only to a track scoring better by `switch_margin` x |current score|
(|current score| taken as at least `SCORE_UNIT`: a margin relative to a score near zero -- a
track whose travel came out near nothing -- would be no margin at all).
When its track is lost (deleted, or coasting past `max_misses`) it re-selects at once, or, with a
`reacquire_time`, waits that long for the same person first: their track found again, or a track
started after the loss where the lost one was heading (`LostTarget.taken_up_by`). Meanwhile
nothing is selected (the camera scans where the target was), so a person hidden for a moment
behind the one beside them is not swapped for that one.

The manual modes come from the select_target service: a track id (kept until that track is
deleted, then back to the automatic policy) or a rectangle (the track whose box overlaps it best,
or else the next track initiated inside it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numpy as np

from tracker_filter.tracking import TrackSet, TrackStatus
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.labels import ANY_LABEL, PERSON, wanted
from tracker_msgs_py.params import check_config, param, specs_of


class SelectionPolicy(IntEnum):
    LARGEST_BLOB = 0
    LONGEST_LIVED = 1
    NEAREST_CENTRE = 2
    MANUAL_ID = 3
    MANUAL_RECT = 4
    FARTHEST_TRAVELLED = 5


#: One unit of every policy's score (1 px of travel or distance, 1 px^2, one frame): the least
#: |score| the switch margin is relative to.
SCORE_UNIT = 1.0

AUTOMATIC_POLICIES = {
    "largest_blob": SelectionPolicy.LARGEST_BLOB,
    "longest_lived": SelectionPolicy.LONGEST_LIVED,
    "nearest_centre": SelectionPolicy.NEAREST_CENTRE,
    "farthest_travelled": SelectionPolicy.FARTHEST_TRAVELLED,
}


def _labels_problem(labels: object) -> str | None:
    if isinstance(labels, list | tuple) and labels and all(labels):
        return None
    return "track_labels must name a label (any: every label)"


@dataclass(frozen=True)
class SelectionConfig:
    """The automatic target selection's parameters, whatever the tracker (the tracker node's and
    the in-process pipeline's); a tracker's preset may give them other defaults."""

    selection_policy: str = param(
        "longest_lived", "automatic target selection", choices=tuple(AUTOMATIC_POLICIES)
    )
    min_lock_time: float = param(
        2.0, "shortest time on a target before switching to another", min=0.0, max=3600.0, unit="s"
    )
    switch_margin: float = param(
        0.2,
        "relative score advantage needed to switch targets (1000: keep the target until lost)",
        min=0.0,
        max=1e6,
    )
    lead_time: float = param(
        0.12, "horizon of the target's predicted position", min=0.0, max=10.0, unit="s"
    )
    target_max_misses: int = param(
        10000,
        "frames a target may coast (no detection) before the camera stops following it",
        min=0,
        max=10000,
    )
    reacquire_time: float = param(
        0.0,
        "after losing the target wait this long for the same person (their track again, or a "
        "new track where they were heading) before selecting another (0: at once)",
        min=0.0,
        max=60.0,
        unit="s",
    )
    track_labels: tuple[str, ...] = param(
        [PERSON],
        "labels of the tracks the camera may follow automatically: person (the person model), "
        "motion (an unclassified blob), any (every label)",
        validator=_labels_problem,
    )

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        return []

    def selector(self) -> TargetSelector:
        """A new target selector with these settings."""
        return TargetSelector(*self._arguments())

    def apply_to(self, selector: TargetSelector) -> None:
        """These settings on a running selector (it keeps its target)."""
        selector.configure(*self._arguments())

    def _arguments(self) -> tuple[SelectionPolicy, float, float, int, float, tuple[str, ...]]:
        return (
            AUTOMATIC_POLICIES[self.selection_policy],
            self.min_lock_time,
            self.switch_margin,
            self.target_max_misses,
            self.reacquire_time,
            tuple(self.track_labels),
        )


#: The selection's parameters and their defaults.
SELECTION_PARAMETERS = specs_of(SelectionConfig)
SELECTION_DEFAULTS: dict[str, Any] = {spec.name: spec.default for spec in SELECTION_PARAMETERS}


@dataclass(frozen=True)
class Selection:
    """The locked track and how it was chosen."""

    track_id: int
    mode: SelectionPolicy
    since: float  # s, scene time the lock started


@dataclass(frozen=True)
class LostTarget:
    """The automatic selection's track while the selector waits for it to come back."""

    track_id: int
    since: float  # s, scene time the lock on it started
    lost_at: float  # s, scene time it stopped being followable
    box: Rect  # its last box while followed (scene px)
    velocity: tuple[float, float]  # px/s, its velocity then
    newest_id: int  # the highest track id at the loss: tracks above it started since

    def taken_up_by(self, tracks: TrackSet, candidates: np.ndarray, now: float) -> int | None:
        """The candidate row that is this person again: their own track, else the oldest track
        started after the loss whose position lies in the lost box carried on at its velocity
        and grown by half its size each way."""
        own = tracks.index_of(self.track_id)
        if own is not None and own in candidates:
            return own
        elapsed = now - self.lost_at
        box, (cx, cy) = self.box, self.box.center
        cx, cy = cx + self.velocity[0] * elapsed, cy + self.velocity[1] * elapsed
        for row in candidates:
            if tracks.ids[row] <= self.newest_id:
                continue
            x, y = tracks.positions[row]
            if abs(x - cx) <= box.width and abs(y - cy) <= box.height:
                return int(row)
        return None


@dataclass(frozen=True)
class SelectResult:
    success: bool
    message: str
    track_id: int | None = None


def _box(bbox: np.ndarray) -> Rect:
    return Rect(*(float(v) for v in bbox))


class TargetSelector:
    """Keeps the current selection across frames; call `update` once per `TrackSet`."""

    def __init__(
        self,
        policy: SelectionPolicy = SelectionPolicy.LONGEST_LIVED,
        min_lock_time: float = 2.0,
        switch_margin: float = 0.2,
        max_misses: int = 10000,
        reacquire_time: float = 0.0,
        labels: tuple[str, ...] = (ANY_LABEL,),
    ) -> None:
        self.configure(policy, min_lock_time, switch_margin, max_misses, reacquire_time, labels)
        self.reset()

    def configure(
        self,
        policy: SelectionPolicy,
        min_lock_time: float,
        switch_margin: float,
        max_misses: int = 10000,
        reacquire_time: float = 0.0,
        labels: tuple[str, ...] = (ANY_LABEL,),
    ) -> None:
        policy = SelectionPolicy(policy)
        if policy not in AUTOMATIC_POLICIES.values():
            raise ValueError(
                f"{policy.name} is chosen through the select_target service, not configured"
            )
        if not (math.isfinite(min_lock_time) and min_lock_time >= 0.0):
            raise ValueError(f"min_lock_time must be >= 0 s, got {min_lock_time}")
        if not (math.isfinite(switch_margin) and switch_margin >= 0.0):
            raise ValueError(f"switch_margin must be >= 0, got {switch_margin}")
        if max_misses < 0:
            raise ValueError(f"max_misses must be >= 0, got {max_misses}")
        if not (math.isfinite(reacquire_time) and reacquire_time >= 0.0):
            raise ValueError(f"reacquire_time must be >= 0 s, got {reacquire_time}")
        if not labels or not all(labels):
            raise ValueError(
                f"track_labels must name at least one label ('any': every label), got {labels}"
            )
        self.policy, self.min_lock_time, self.switch_margin = policy, min_lock_time, switch_margin
        self.max_misses, self.reacquire_time = max_misses, reacquire_time
        self.labels = tuple(labels)

    def reset(self) -> None:
        """Back to the automatic policy with nothing locked."""
        self.selection: Selection | None = None
        self._manual: SelectionPolicy | None = None
        self._pending_rect: Rect | None = None
        self._pending_after_id = 0  # a pending rectangle takes tracks with ids above this one
        self._last_tracks: TrackSet | None = None
        self._lost: LostTarget | None = None  # the automatic target waited for
        # the followed track's last box and velocity, and the newest track id then
        self._followed: tuple[Rect, tuple[float, float], int] | None = None

    @property
    def mode(self) -> SelectionPolicy:
        return self._manual if self._manual is not None else self.policy

    # --- service requests ---------------------------------------------------------------------

    def select_auto(self) -> SelectResult:
        self._unlock()
        if self._last_tracks is not None:
            self.update(self._last_tracks)
        chosen = self.selection.track_id if self.selection else None
        return SelectResult(True, f"automatic selection ({self.policy.name.lower()})", chosen)

    def _unlock(self) -> None:
        last = self._last_tracks
        self.reset()
        self._last_tracks = last

    def select_id(self, track_id: int) -> SelectResult:
        tracks = self._last_tracks
        index = tracks.index_of(track_id) if tracks is not None else None
        if tracks is None or index is None or tracks.status[index] == TrackStatus.LOST:
            return SelectResult(False, f"no live track with id {track_id}")
        self._unlock()
        self._manual = SelectionPolicy.MANUAL_ID
        self.selection = Selection(int(track_id), SelectionPolicy.MANUAL_ID, tracks.time)
        return SelectResult(True, f"following track {track_id}", int(track_id))

    def select_rectangle(self, rect: Rect) -> SelectResult:
        if not (rect.width > 0.0 and rect.height > 0.0):
            return SelectResult(False, f"the rectangle must have a positive size, got {rect}")
        self._unlock()
        self._manual = SelectionPolicy.MANUAL_RECT
        tracks = self._last_tracks
        if tracks is not None:
            live = tracks.status != TrackStatus.LOST
            overlaps = np.array(
                [
                    rect.iou(_box(b)) if ok else 0.0
                    for b, ok in zip(tracks.bboxes, live, strict=True)
                ]
            )
            inside = np.array(
                [rect.contains(*p) and ok for p, ok in zip(tracks.positions, live, strict=True)],
                dtype=bool,
            )
            score = (
                overlaps + inside
            )  # a centre inside the rectangle counts even for a point-sized box
            if score.size and score.max() > 0.0:
                track_id = int(tracks.ids[int(np.argmax(score))])
                self.selection = Selection(track_id, SelectionPolicy.MANUAL_RECT, tracks.time)
                return SelectResult(True, f"following track {track_id}", track_id)
            self._pending_after_id = int(tracks.ids.max()) if len(tracks) else 0
        self._pending_rect = rect
        return SelectResult(True, "no track in the rectangle yet: waiting for one to start there")

    # --- per frame ----------------------------------------------------------------------------

    def update(
        self,
        tracks: TrackSet,
        view_centre: tuple[float, float] | None = None,
        allowed: np.ndarray | None = None,
    ) -> Selection | None:
        """The selection after this frame's tracks (None: nothing to follow). `allowed` (a mask
        over the tracks, None: all) limits the automatic policy (the required zones)."""
        self._last_tracks = tracks
        if self._pending_rect is not None:
            self._take_track_started_in_rect(tracks)
            return self.selection
        if self._manual is not None:
            if self.selection is not None and self._alive(tracks, self.selection.track_id):
                return self.selection
            self._unlock()  # the chosen track is gone: back to the automatic policy
        return self._update_automatic(tracks, view_centre, allowed)

    def _take_track_started_in_rect(self, tracks: TrackSet) -> None:
        rect = self._pending_rect
        assert rect is not None, "called only while a rectangle is pending"
        for i in np.flatnonzero(tracks.ids > self._pending_after_id):
            if tracks.status[i] != TrackStatus.LOST and rect.contains(*tracks.positions[i]):
                self.selection = Selection(
                    int(tracks.ids[i]), SelectionPolicy.MANUAL_RECT, tracks.time
                )
                self._pending_rect = None
                return
        if len(tracks):
            self._pending_after_id = max(self._pending_after_id, int(tracks.ids.max()))

    @staticmethod
    def _alive(tracks: TrackSet, track_id: int) -> bool:
        index = tracks.index_of(track_id)
        return index is not None and tracks.status[index] != TrackStatus.LOST

    def _scores(self, tracks: TrackSet, view_centre: tuple[float, float] | None) -> np.ndarray:
        if self.policy is SelectionPolicy.LARGEST_BLOB:
            return tracks.areas.astype(float)
        if self.policy is SelectionPolicy.NEAREST_CENTRE and view_centre is not None:
            nearness: np.ndarray = -np.hypot(
                *(tracks.positions - np.asarray(view_centre, dtype=float)).T
            )
            return nearness
        if self.policy is SelectionPolicy.FARTHEST_TRAVELLED:
            assert tracks.travel is not None and tracks.straightness is not None  # __post_init__
            travelled: np.ndarray = tracks.travel * tracks.straightness
            return travelled
        return tracks.ages.astype(float)

    def _update_automatic(
        self,
        tracks: TrackSet,
        view_centre: tuple[float, float] | None,
        allowed: np.ndarray | None = None,
    ) -> Selection | None:
        confirmed = (tracks.status == TrackStatus.CONFIRMED) | (
            tracks.status == TrackStatus.COASTING
        )
        followed = wanted(tracks.labels, self.labels)
        if allowed is not None:
            followed = followed & allowed
        candidates = np.flatnonzero(confirmed & followed & (tracks.misses <= self.max_misses))
        current = self.selection
        incumbent = tracks.index_of(current.track_id) if current is not None else None
        if current is not None and (incumbent is None or incumbent not in candidates):
            self._lose(current, tracks.time)
            incumbent = None
        if self._lost is not None:
            incumbent = self._wait_for_lost(tracks, candidates)
            if self._lost is not None:
                return None
        if incumbent is not None:
            self._switch_if_better(tracks, candidates, incumbent, view_centre)
        elif candidates.size:
            scores = self._scores(tracks, view_centre)
            best = int(candidates[np.argmax(scores[candidates])])  # ties: the oldest (lowest) row
            self.selection = Selection(int(tracks.ids[best]), self.policy, tracks.time)
        self._remember(tracks)
        return self.selection

    def _switch_if_better(
        self,
        tracks: TrackSet,
        candidates: np.ndarray,
        incumbent: int,
        view_centre: tuple[float, float] | None,
    ) -> None:
        """Hysteresis: leave the selected track (row `incumbent`) only after `min_lock_time`
        and for a track scoring better by `switch_margin` x |its score| (at least SCORE_UNIT)."""
        current = self.selection
        assert current is not None, "called only with a selection"
        if tracks.time - current.since < self.min_lock_time:
            return
        scores = self._scores(tracks, view_centre)
        best = int(candidates[np.argmax(scores[candidates])])  # ties: the oldest (lowest) row
        threshold = scores[incumbent] + self.switch_margin * max(abs(scores[incumbent]), SCORE_UNIT)
        if best != incumbent and scores[best] > threshold:
            self.selection = Selection(int(tracks.ids[best]), self.policy, tracks.time)

    def _lose(self, current: Selection, now: float) -> None:
        """The selected track can no longer be followed: wait for it, or re-select at once."""
        self.selection = None
        if self.reacquire_time > 0.0 and self._followed is not None:
            box, velocity, newest_id = self._followed
            self._lost = LostTarget(current.track_id, current.since, now, box, velocity, newest_id)

    def _wait_for_lost(self, tracks: TrackSet, candidates: np.ndarray) -> int | None:
        """The row that took the lost target's lock up, if one did this frame."""
        lost = self._lost
        assert lost is not None, "called only while waiting"
        row = lost.taken_up_by(tracks, candidates, tracks.time)
        if row is not None:
            self.selection = Selection(int(tracks.ids[row]), self.policy, lost.since)
            self._lost = None
        elif tracks.time - lost.lost_at >= self.reacquire_time:
            self._lost = None  # waited long enough: anyone may be chosen
        return row

    def _remember(self, tracks: TrackSet) -> None:
        """The selected track's box and velocity, and the newest track id, for `_lose`."""
        row = None
        if self.reacquire_time > 0.0 and self.selection is not None:
            row = tracks.index_of(self.selection.track_id)
        if row is None:
            self._followed = None
            return
        vx, vy = (float(v) for v in tracks.velocities[row])
        newest_id = int(tracks.ids.max())
        self._followed = (_box(tracks.bboxes[row]), (vx, vy), newest_id)
