"""Seed 004's multi-target tracker: GM-PHD filter, occlusion handling, Hungarian labels (no rclpy).

A `tracking.Tracker` (method `gm_phd`). Each frame:
1. `gmphd.GmPhdFilter` steps on the detections' centroids; occluded tracks' Gaussians are kept
   alive by `phd_occlusion.OcclusionMonitor` (tags, injection, persistence factor), and every
   unidentified-object region adds a birth Gaussian;
2. the extracted states are labelled by `phd_labels` (Hungarian on Mahalanobis cost, impulse);
   extracted states that no track takes and that come from a measurement no track used start new
   tracks;
3. a track is a hit when its state came from a measurement no better-matching track used; a
   track with at least `LINE_HITS` hits (a fitted line to dead-reckon by) not hit inside
   another's possible-occlusion circle (at its predicted position, or at
   its dead reckoning when it had come near another track), or inside an unidentified-object
   region, becomes occluded; an occluded track hit again ends its occlusion, and its visible
   partner, when its state has strayed from its own dead reckoning with the blob, is placed by
   that in the next frame's labelling;
4. a confirmed track with a fitted line whose detection is missed for one frame away from any
   occlusion and from the view's borders keeps its Gaussian's whole weight for that frame
   (`bridge_missed`; not the thesis's): its missed-detection term is 1 instead of 1 - p_D, so
   the next detection near its prediction continues it (else one miss in 50 drops a target's
   weight to 0.02 and it is found again only as a new birth two frames later);
5. bookkeeping by `tracking.TrackBook`: confirmed after `confirm_hits` hits, LOST after more than
   `max_misses` frames without a state of its own (without a hit, when it is not occluded); a
   confirmed track lost without an occlusion away from the view's borders marks an unidentified
   object there;
6. stitching: for `stitch_frames` frames after a track leaves an occlusion region or a confirmed
   track is lost, its label goes to the confirmed track that best fits its dead reckoning
   (`_stitch`).

Layout "x y vx vy" (px, px/s); `existence` is the weight of the track's Gaussian (at most 1).
The camera window gives the view's borders and, with `area` 0, the clutter density's area; a
frame without it still updates every track.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tracker_filter.gm_phd import gmphd
from tracker_filter.gm_phd.gmphd import Estimates, GmPhdConfig, GmPhdFilter, Mixture
from tracker_filter.gm_phd.phd_labels import (
    BARRED,
    LabelledStates,
    assign,
    inside_merged_blob,
    labelling_costs,
)
from tracker_filter.gm_phd.phd_occlusion import OcclusionConfig, OcclusionMonitor
from tracker_filter.layout import StateLayout
from tracker_filter.models import CONSTANT_VELOCITY
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

LAYOUT = StateLayout.from_names("x y vx vy")
FIRST_INTERVAL = 1.0  # s, the first frame's (nothing to predict yet)


@dataclass(frozen=True)
class BirthSites:
    """A static birth mixture (Vo & Ma's): targets appear at `points` (N, 2) px, standing or
    moving any way: a Gaussian of position std `position_std` px, zero mean velocity of std
    `speed_std` px/s, and weight `weight`, at every site, every frame."""

    points: np.ndarray
    weight: float
    position_std: float
    speed_std: float

    def mixture(self) -> Mixture:
        count = len(self.points)
        means = np.column_stack([self.points, np.zeros((count, 2))])
        variances = [self.position_std**2] * 2 + [self.speed_std**2] * 2
        covariances = np.broadcast_to(np.diag(variances), (count, 4, 4))
        return Mixture.of(np.full(count, self.weight), means, covariances)


def _pairs(value: Any) -> str | None:
    if len(value) % 2 or not all(np.isfinite(v) for v in value):
        return "birth_sites must be finite x, y pairs"
    return None


@dataclass
class OcclusionExit:
    """A label that just left an occlusion region, or whose confirmed track was lost: the clean
    state it is dead-reckoned from (position and mean velocity) and that state's time, the first
    track id that may have been started for its target meanwhile, and the frames it stays open."""

    state: np.ndarray
    time: float
    first_id: int
    frames_left: int


#: Per-track arrays kept in the TrackBook's row order.
_ROW_FIELDS = (
    "states",
    "covariances",
    "weights",
    "unassigned",
    "mean_velocities",
    "mean_positions",
    "history_times",
    "history_points",
)
#: Hits a fitted line needs: fewer give no kept speed and heading to dead-reckon by.
LINE_HITS = 3
#: Std of an occluded track's velocity, as a share of its speed.
OCCLUDED_SPEED_SPREAD = 0.1
#: x the measurement noise: a visible partner this far off its dead reckoning when the track it
#: hid comes out followed the blob, not its target (`_reckon_partners`)
PARTNER_OFF_COURSE = 2.0
#: squared Mahalanobis units such a partner pays to take an estimate by its own state instead (its
#: target may simply have turned: the line is a guess)
PARTNER_STATE_COST = 4.0


def _dead_reckoning(state: np.ndarray, gap: float) -> tuple[np.ndarray, float]:
    """Where a clean state (position, mean velocity) puts its target `gap` s later, and the
    variance of that guess per axis (the speed is known to within a share of itself)."""
    spread = OCCLUDED_SPEED_SPREAD * np.hypot(*state[2:]) * gap
    return state[:2] + gap * state[2:], float(spread**2)


_F = GmPhdConfig()
_O = OcclusionConfig()
DEFAULT_AREA = 640.0 * 480.0  # px^2, the clutter's area with `area` 0 until a window tells it


@dataclass(frozen=True)
class GmPhdTrackerConfig:
    """Parameters of the `gm_phd` method: the filter's (`filter_config`), the occlusion
    monitor's (`occlusion`), the static birth sites (`static_births`) and the labelling's."""

    survival: float = param(_F.survival, "p_S, survival probability per frame", min=0.01, max=1.0)
    detection: float = param(_F.detection, "p_D, detection probability", min=0.01, max=1.0)
    clutter_rate: float = param(5.0, "lambda_c, false detections per frame", min=0.0, max=1e6)
    area: float = param(
        0.0,
        "area the clutter spreads over (0: the camera window's area)",
        min=0.0,
        max=1e12,
        unit="px^2",
    )
    process_noise: float = param(
        150.0, "sigma_v, acceleration noise", min=1e-3, max=1e6, unit="px/s^2"
    )
    measurement_noise: float = param(3.0, "sigma_r, centroid noise", min=1e-3, max=1e4, unit="px")
    prune_threshold: float = param(
        _F.prune_threshold, "T, components lighter are dropped", min=0.0, max=1.0
    )
    merge_threshold: float = param(
        _F.merge_threshold, "U, squared Mahalanobis merge distance", min=0.0, max=1e4
    )
    max_components: int = param(500, "J_max, Gaussians kept at most", min=1, max=100000)
    extract_threshold: float = param(
        _F.extract_threshold, "a Gaussian heavier is a target", min=0.01, max=1.0
    )
    continue_threshold: float = param(
        0.2,
        "a Gaussian heavier continues an existing track (hysteresis: a track survives the low "
        "weight one missed detection leaves)",
        min=0.0,
        max=1.0,
    )
    birth_weight: float = param(
        _F.birth_weight, "weight of the births one detection makes", min=0.0, max=1.0
    )
    max_birth_speed: float = param(
        400.0, "speed between the two detections of a birth", min=1e-3, max=1e6, unit="px/s"
    )
    birth_gate: float = param(
        _F.birth_gate, "a detection explained this well by targets births none", min=0.01, max=1.0
    )
    spawn_weight: float = param(
        _F.spawn_weight, "spawned Gaussians per target (0: none)", min=0.0, max=1.0
    )
    occlusion_handling: bool = param(_O.enabled, "seed 004's occlusion regions and persistence")
    persistence_floor: float = param(_O.floor, "P_d^occl never below this", min=0.01, max=1.0)
    mean_occlusion: float = param(
        _O.mean_occlusion, "frames an occlusion lasts until one is seen", min=1.0, max=1e4
    )
    object_size: float = param(
        _O.object_size, "occlusion radius without sized boxes", min=0.0, max=1e4, unit="px"
    )
    border_margin: float = param(
        _O.border_margin,
        "deaths this near the view's edge are exits",
        min=0.0,
        max=1e4,
        unit="px",
    )
    birth_sites: tuple[float, ...] = param(
        [0.0, 0.0],
        "static birth mixture: where targets appear, as [x1, y1, x2, y2, ...] "
        "(used when birth_site_weight > 0)",
        unit="scene px",
        validator=_pairs,
    )
    birth_site_weight: float = param(
        0.0, "weight of each birth site's Gaussian (0: none)", min=0.0, max=1.0
    )
    birth_site_position_std: float = param(
        10.0, "position std of a birth site", min=0.01, max=1e5, unit="px"
    )
    birth_site_speed_std: float = param(
        100.0, "speed std of a birth site's targets", min=0.0, max=1e6, unit="px/s"
    )
    label_gate: float = param(
        16.0, "squared Mahalanobis distance a label reaches", min=0.1, max=1e6
    )
    impulse: float = param(
        0.5, "cost factor of candidates ahead of an occluded track", min=0.0, max=1.0
    )
    stitch_frames: int = param(
        5,
        "frames after an occlusion or a confirmed track's loss during which its label goes to "
        "the track that fits its kept speed and heading (0: never)",
        min=0,
        max=1000,
    )
    bridge_missed: bool = param(
        True,
        "a confirmed track missed for one frame (away from occlusions and the view's borders) "
        "keeps its Gaussian's weight for that frame: missed-detection term 1, not 1 - p_D "
        "(not the thesis's)",
    )
    velocity_history: int = param(
        10,
        "hits a track's kept speed and heading (the line it is dead-reckoned by) are fitted over: "
        "longer is steadier on straight paths and lags a target that turns",
        min=LINE_HITS,
        max=1000,
    )
    confirm_hits: int = param(2, "hits before a track is confirmed", min=1, max=1000)
    max_misses: int = param(
        3, "frames without its own state after which a track is lost", min=0, max=1000
    )

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """What the filter and the occlusion monitor reject of the configs these fields make: the
        fields' ranges already hold all of it but merge_threshold > 0 (U = 0 is in its range)."""
        return self.filter_config().problems() + self.occlusion().problems()

    @property
    def window_area(self) -> bool:
        """Whether the clutter spreads over the camera window (`area` 0)."""
        return float(self.area) <= 0

    def filter_config(self) -> GmPhdConfig:
        area = float(self.area)
        return GmPhdConfig(
            survival=self.survival,
            detection=self.detection,
            clutter_rate=self.clutter_rate,
            area=area if area > 0 else DEFAULT_AREA,
            process_noise=self.process_noise,
            measurement_noise=self.measurement_noise,
            prune_threshold=self.prune_threshold,
            merge_threshold=self.merge_threshold,
            max_components=self.max_components,
            extract_threshold=self.extract_threshold,
            birth_weight=self.birth_weight,
            max_birth_speed=self.max_birth_speed,
            birth_gate=self.birth_gate,
            spawn_weight=self.spawn_weight,
        )

    def occlusion(self) -> OcclusionConfig:
        return OcclusionConfig(
            enabled=self.occlusion_handling,
            floor=self.persistence_floor,
            mean_occlusion=self.mean_occlusion,
            object_size=self.object_size,
            border_margin=self.border_margin,
        )

    def static_births(self) -> BirthSites | None:
        """The birth sites the fields describe, None when birth_site_weight is 0."""
        if self.birth_site_weight <= 0:
            return None
        points = np.asarray(self.birth_sites, dtype=float).reshape(-1, 2)
        return BirthSites(
            points, self.birth_site_weight, self.birth_site_position_std, self.birth_site_speed_std
        )


class GmPhdTracker:
    """GM-PHD with seed 004's occlusion handling and labelling, as a `tracking.Tracker`."""

    needs = frozenset({Need.WINDOW})
    layout = LAYOUT

    def __init__(self, config: GmPhdTrackerConfig, first_id: int = 1) -> None:
        filter_config = config.filter_config()
        birth_sites = config.static_births()
        self.config = filter_config
        self.filter = GmPhdFilter(
            filter_config, birth_sites.mixture() if birth_sites is not None else None
        )
        self.monitor = OcclusionMonitor(config.occlusion())
        self.label_gate, self.impulse = config.label_gate, config.impulse
        self.confirm_hits, self.max_misses = config.confirm_hits, config.max_misses
        self.window_area = config.window_area
        self.continue_threshold = config.continue_threshold
        self.stitch_frames = config.stitch_frames
        self.bridge_missed = config.bridge_missed
        # hits (time, position) the mean velocity is fitted to
        self.velocity_history = config.velocity_history
        self.book = TrackBook(first_id)
        self._clear()

    def _clear(self) -> None:
        self.states = np.zeros((0, LAYOUT.dim))
        self.covariances = np.zeros((0, LAYOUT.dim, LAYOUT.dim))
        self.weights = np.zeros(0)
        self.unassigned = np.zeros(0, np.int64)  # consecutive frames without a state of its own
        # the thesis's kept "average speed": a straight line fitted to the last hits' measured
        # positions (least squares), steadier than the filter's velocity for dead reckoning; an
        # occluded track's Gaussian is dead-reckoned from it (not from the states a merged blob
        # pulled off course)
        self.mean_velocities = np.zeros((0, 2))  # px/s
        self.mean_positions = np.zeros((0, 2))  # px, the fitted line at the last hit
        history = self.velocity_history
        self.history_times = np.zeros((0, history))  # NaN: no hit; the last is the latest
        self.history_points = np.zeros((0, history, 2))
        self.pending = Mixture.empty()  # Gaussians of tracks occluded at the last frame
        self._epsilon_now = self.monitor.config.object_size  # px, this frame's occlusion radius
        self._now = 0.0  # s, the step being processed
        # per label inside an occlusion region: its state at the region's start and that time
        self.anchors: dict[int, tuple[np.ndarray, float]] = {}
        self._explained: np.ndarray = np.zeros(0, dtype=bool)  # per estimate: within a track's gate
        # labels inside an occlusion region, each with the book's next id when it went in
        self._involved: dict[int, int] = {}
        self.exits: dict[int, OcclusionExit] = {}
        # labels of visible partners placed by dead reckoning in the next frame's labelling
        self.reckon_next: set[int] = set()

    @property
    def next_id(self) -> int:
        return self.book.next_id

    def reset(self, reset_ids: bool = False) -> int:
        self.filter.reset()
        self.monitor.reset()
        self._clear()
        return self.book.reset(reset_ids)

    def _adopt_window_area(self, observation: Observation) -> None:
        window = observation.window
        if self.window_area and window is not None and window.width * window.height > 0:
            area = float(window.width * window.height)
            if area != self.filter.config.area:
                self.filter.config = replace(self.filter.config, area=area)

    def _epsilon(self, boxes: np.ndarray) -> float:
        """The mean object size of the frame: the possible-occlusion radius."""
        sizes = boxes[:, 2:].max(axis=1) if len(boxes) else np.zeros(0)
        sizes = sizes[sizes > 0]
        return float(sizes.mean()) if len(sizes) else self.monitor.config.object_size

    def _label(
        self, estimates: Estimates, measured: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Assigned rows and estimate columns, and per row whether its state is a hit (of the
        `measured` positions); marks in `self._explained` the estimates an existing track could
        have taken (within the gate of one): they never start a track (the PHD update gives a
        clutter point near a target almost the target's whole weight; that is one target, not
        two)."""
        tracks = self._labelled_states()
        noise = self.config.measurement_noise**2
        costs = labelling_costs(tracks, estimates, noise, self.impulse, self.label_gate)
        if self.reckon_next:
            by_state = labelling_costs(
                self._labelled_states(reckon_partners=False),
                estimates,
                noise,
                self.impulse,
                self.label_gate,
            )
            rows = np.flatnonzero(np.isin(self.book.ids, list(self.reckon_next)))
            costs[rows] = np.minimum(costs[rows], by_state[rows] + PARTNER_STATE_COST)
        self._explained = np.asarray((costs <= self.label_gate).any(axis=0))
        rows, cols = assign(costs, self.label_gate)
        hit = np.zeros(len(self.book), dtype=bool)
        sources = estimates.sources[cols].copy()
        # an occluded track's wide Gaussian also reaches false alarms: it is back only when a
        # measurement makes it a target again (weight above the extraction threshold)
        sources[
            tracks.hidden[rows] & (estimates.weights[cols] <= self.config.extract_threshold)
        ] = -1
        # a measurement shared by several tracks (a merged blob) is the hit of the nearest only
        for source in np.unique(sources[sources >= 0]):
            sharing = np.flatnonzero(sources == source)
            best = sharing[np.argmin(costs[rows[sharing], cols[sharing]])]
            hit[rows[best]] = True
        hit_points = np.full((len(hit), 2), np.nan)
        hit_points[rows[sources >= 0]] = measured[sources[sources >= 0]]
        hit &= ~inside_merged_blob(tracks, hit, hit_points, self._epsilon_now)
        return rows, cols, hit

    def step(self, observation: Observation) -> TrackSet:
        t, book = observation.time, self.book
        book.check_time(t)
        self._now = t
        dt = t - book.time if book.time is not None else FIRST_INTERVAL
        detections, rejections = observation.detections.validated()
        self._adopt_window_area(observation)
        config = self.filter.config
        region_births = self.monitor.region_births(
            config.measurement_noise, config.max_birth_speed / 2
        )
        self._reanchor_tagged()
        estimates = self.filter.step(
            detections.positions,
            dt,
            self.pending,
            lambda predicted: self.monitor.detection_terms(predicted.tags, config.detection),
            min(self.continue_threshold, config.extract_threshold),
            region_births,
        )
        self._drop_stray_tagged()
        # every track predicted to t (coasting); those given a state take it below
        transition = CONSTANT_VELOCITY.transition(dt)
        noise = CONSTANT_VELOCITY.process_noise(dt, config.process_noise)
        self.states = self.states @ transition.T
        self.covariances = transition @ self.covariances @ transition.T + noise
        self.weights = config.survival * self.weights
        rows, cols, hit = self._label(estimates, detections.positions)
        self.states[rows] = estimates.means[cols]
        self.covariances[rows] = estimates.covariances[cols]
        self.weights[rows] = estimates.weights[cols]
        self.unassigned += 1
        self.unassigned[rows] = 0
        predicted_weights = self.weights.copy()
        self.weights[self.unassigned > 0] = 0.0  # no Gaussian of its own: a prediction
        hit_rows = np.flatnonzero(hit)
        sources = np.full(len(book), -1, np.int64)
        sources[rows] = estimates.sources[cols]
        self._fit_velocities(hit_rows, t, detections.positions[sources[hit_rows]])
        book.record_frame(hit_rows, sources[hit_rows], detections, LAYOUT.positions(self.states))
        window = observation.window
        bounds = None if window is None else (window.x, window.y, window.width, window.height)
        self._occlusions(t, hit, detections.bboxes)
        if self.bridge_missed:
            self._bridge_missed(bounds, predicted_weights)
        self._note_exits()
        lost = self._lost(bounds)
        self._update_anchors()
        count = len(book)
        self._start_tracks(t, estimates, cols, detections)
        added = len(book) - count
        lost = np.concatenate([lost, np.zeros(added, dtype=bool)])
        updated = np.concatenate([hit, np.ones(added, dtype=bool)])
        book.confirm(book.hits >= self.confirm_hits)
        self._stitch(t, lost)
        tracks = book.snapshot(
            t,
            LAYOUT,
            self.states.copy(),
            self.covariances.copy(),
            updated,
            lost,
            rejections,
            existence=np.minimum(self.weights, 1.0),
        )
        self._drop(lost)
        book.finish(t)
        return tracks

    def _fit_velocities(self, rows: np.ndarray, t: float, measured: np.ndarray) -> None:
        """Add the hits (measured positions (R, 2) at t) to the rows' histories and refit their
        mean velocities: the least-squares slope of position over time."""
        if not len(rows):
            return
        times = np.roll(self.history_times[rows], -1, axis=1)
        points = np.roll(self.history_points[rows], -1, axis=1)
        times[:, -1], points[:, -1] = t, measured
        self.history_times[rows], self.history_points[rows] = times, points
        valid = np.isfinite(times)
        count = valid.sum(axis=1)
        centred = np.where(valid, times - np.nanmean(times, axis=1, keepdims=True), 0.0)
        spread = (centred**2).sum(axis=1)
        mean_point = (points * valid[..., None]).sum(axis=1) / count[:, None]
        slope = (centred[..., None] * (points - mean_point[:, None])).sum(axis=1)
        fitted = (count >= LINE_HITS) & (spread > 0)
        velocity = np.where(
            fitted[:, None],
            slope / np.where(spread > 0, spread, 1.0)[:, None],
            self.states[rows, 2:],
        )
        self.mean_velocities[rows] = velocity
        latest = (t - np.nanmean(times, axis=1))[:, None]
        self.mean_positions[rows] = np.where(
            fitted[:, None], mean_point + velocity * latest, measured
        )

    def _reanchor_tagged(self) -> None:
        """Put every coasting tagged Gaussian (a hidden track's, or its visible partner's) back
        on its track's dead reckoning at the last step's time: the filter's own prediction would
        widen it by the motion model's noise each frame until no measurement could find it again
        (the kept speed is steadier than that)."""
        if self.book.time is None:
            return
        mixture = self.filter.mixture
        tags = set(mixture.tags[mixture.tags > 0].tolist())
        rows = [row for row, label in enumerate(self.book.ids.tolist()) if label in tags]
        if not rows:
            return
        means, covariances = mixture.means.copy(), mixture.covariances.copy()
        placed, spread = self._since_hit(np.array(rows), self.book.time)
        for row, mean, covariance in zip(rows, placed, spread, strict=True):
            mine = mixture.tags == self.book.ids[row]
            means[mine], covariances[mine] = mean, covariance
        self.filter.mixture = replace(mixture, means=means, covariances=covariances)

    def _drop_stray_tagged(self) -> None:
        """An occluded track is one Gaussian: its tagged components too light to be it (below
        half the continuation threshold) are false alarms it brushed, not the target."""
        mixture = self.filter.mixture
        stray = (mixture.tags > 0) & (mixture.weights < self.continue_threshold / 2)
        if stray.any():
            self.filter.mixture = mixture.subset(np.flatnonzero(~stray))

    def _labelled_states(self, reckon_partners: bool = True) -> LabelledStates:
        """The tracks as labelling sees them. A track inside an occlusion region -- hidden, or
        the visible one whose blob hides another -- is placed by dead reckoning from its last
        clean hit with its mean velocity (the thesis's kept speed and heading), with the spread
        of that guess: the blob it follows is where both targets are not. So are, with
        `reckon_partners`, the partners of tracks that came out of hiding at the last frame
        (`_reckon_partners`)."""
        reckoned = self.reckon_next if reckon_partners else set()
        count = len(self.book)
        positions, velocities = self.states[:, :2].copy(), self.states[:, 2:].copy()
        variances = np.zeros(count)
        centres = np.full((count, 2), np.nan)
        labels = self.book.ids.tolist()
        partners = self.monitor.partners()
        for row, label in enumerate(labels):
            occlusion = self.monitor.occluded.get(label)
            if occlusion is not None:
                centres[row] = occlusion.centre
            if occlusion is None and label not in partners and label not in reckoned:
                continue
            state, time = self._anchor(row)
            positions[row], variances[row] = _dead_reckoning(state, self._now - time)
            velocities[row] = state[2:]
            if label in partners and occlusion is None:  # the region is its hidden partner's
                hiding = [o for o in self.monitor.occluded.values() if o.partner == label]
                centres[row] = hiding[0].centre
        hidden = np.isin(self.book.ids, list(self.monitor.occluded))
        return LabelledStates(self.book.ids, positions, velocities, variances, centres, hidden)

    def _since_hit(self, rows: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The states of `rows` at t dead-reckoned from their anchors (else their last hits)
        with their mean velocities, and covariances widened by the speed's uncertainty."""
        means = np.zeros((len(rows), LAYOUT.dim))
        covariances = np.zeros((len(rows), LAYOUT.dim, LAYOUT.dim))
        for i, row in enumerate(rows):
            last, time = self._anchor(int(row))
            gap = t - time
            transition = CONSTANT_VELOCITY.transition(gap)
            # the speed is known to within a share of itself (the line through its hits is
            # steadier than the filter's young covariance): where the hidden target comes out
            r2 = self.config.measurement_noise**2
            speed_spread = OCCLUDED_SPEED_SPREAD * np.hypot(*last[2:])
            speed_var = speed_spread**2 + r2 / self.velocity_history
            anchored = np.diag([r2, r2, speed_var, speed_var])
            means[i] = transition @ last
            covariances[i] = transition @ anchored @ transition.T
        return means, covariances

    def _anchor(self, row: int) -> tuple[np.ndarray, float]:
        """The clean state (position, mean velocity) a track is dead-reckoned from, and its
        time: the anchor taken when it came near another track, else its last hit."""
        label = int(self.book.ids[row])
        if label in self.anchors:
            return self.anchors[label]
        state = np.concatenate([self.mean_positions[row], self.mean_velocities[row]])
        return state, float(self.history_times[row, -1])

    def _update_anchors(self) -> None:
        """Anchor every confirmed track that comes within twice the possible-occlusion radius
        of another (before their blobs merge and pull its state and velocity off course); free
        the anchors of tracks apart again and not in an occlusion region."""
        positions = LAYOUT.positions(self.states)
        labels = self.book.ids.tolist()
        confirmed = self.book.confirmed
        near = np.zeros(len(labels), dtype=bool)
        if len(labels) > 1:
            gaps = np.linalg.norm(positions[:, None] - positions[None], axis=2)
            np.fill_diagonal(gaps, np.inf)
            close = gaps <= 2.0 * self._epsilon_now
            near = (close & confirmed[None, :]).any(axis=1) & confirmed
        in_regions = self.monitor.involved()
        for row, label in enumerate(labels):
            if near[row] and label not in self.anchors:
                self.anchors[label] = self._anchor(row)
            elif not near[row] and label not in in_regions:
                self.anchors.pop(label, None)

    def _occlusions(
        self,
        t: float,
        hit: np.ndarray,
        boxes: np.ndarray,
    ) -> None:
        labels = self.book.ids
        hiding = {label: o.partner for label, o in self.monitor.occluded.items() if o.partner}
        back = self.monitor.advance(labels, hit)
        self._reckon_partners(t, [hiding[label] for label in back if label in hiding])
        in_regions = self.monitor.involved()
        mixture = self.filter.mixture
        done = (mixture.tags > 0) & ~np.isin(mixture.tags, list(in_regions))
        if done.any():  # their occlusions ended: ordinary Gaussians again
            self.filter.mixture = replace(mixture, tags=np.where(done, 0, mixture.tags))
        self._epsilon_now = self._epsilon(boxes)
        # only a track with a fitted line can be dead-reckoned while hidden: a younger one
        # (often born of false alarms) that goes undetected beside a target is just lost
        lined = self._lined()
        hidden = ~hit & self.book.confirmed & lined
        positions = LAYOUT.positions(self.states)
        begun = self.monitor.begin(labels, positions, hidden, self._epsilon_now)
        begun += self._begin_reckoned(t, labels, positions, hidden)
        self.pending = Mixture.empty()
        if not begun:
            return
        partners = {self.monitor.occluded[int(labels[row])].partner for row in begun}
        tagged = set(self.filter.mixture.tags.tolist())
        extra = [
            row
            for row, label in enumerate(labels.tolist())
            if label in partners and label not in tagged and row not in begun
        ]
        rows = np.array(begun + extra)
        means, covariances = self._since_hit(rows, t)
        self.pending = Mixture.of(np.ones(len(rows)), means, covariances, labels[rows])
        self.weights[begun] = np.maximum(self.weights[begun], 1.0)

    def _lined(self) -> np.ndarray:
        """Per track, whether it has a fitted line (LINE_HITS hits) to dead-reckon by."""
        lined: np.ndarray = np.isfinite(self.history_times).sum(axis=1) >= LINE_HITS
        return lined

    def _reckon_partners(self, t: float, partners: list[int]) -> None:
        """The visible partners of tracks that came out of hiding this frame, no longer in an
        occlusion region, whose states lie more than PARTNER_OFF_COURSE x the measurement noise
        off their own dead reckoning, are placed by it in the next frame's labelling (as inside
        the region): their states followed the blob, and the blob may still hold another target
        (scenario 1's, born in the crossing) that goes on where the blob goes. An estimate by its
        state stays open to such a partner at PARTNER_STATE_COST more (`_label`)."""
        still = self.monitor.involved()
        rows = {label: row for row, label in enumerate(self.book.ids.tolist())}
        chosen = [rows[p] for p in partners if p in rows and p not in still]
        self.reckon_next = set()
        if not chosen:
            return
        reckoned = self._since_hit(np.array(chosen), t)[0][:, :2]
        gaps = np.hypot(*(reckoned - self.states[chosen, :2]).T)
        limit = PARTNER_OFF_COURSE * self.config.measurement_noise
        off_course = np.array(chosen)[gaps > limit]
        self.reckon_next = set(self.book.ids[off_course].tolist())

    def _bridge_missed(
        self, bounds: tuple[float, float, float, float] | None, predicted_weights: np.ndarray
    ) -> None:
        """Give back the share p_D of their predicted weight that the PHD update took from the
        Gaussians of confirmed, lined tracks missed for the first time this frame, away from
        occlusions and the view's borders (module doc, 4.): injected at their predicted states
        for the next frame, beside the (1 - p_D) share the filter kept."""
        lined = self._lined()
        in_regions = self.monitor.involved()
        positions = LAYOUT.positions(self.states)
        candidates = np.flatnonzero(
            self.book.confirmed
            & lined
            & (self.unassigned == 1)
            & ~np.isin(self.book.ids, list(in_regions))
        )
        rows = np.array(
            [row for row in candidates if self.monitor.away_from_border(positions[row], bounds)],
            dtype=np.int64,
        )
        if not len(rows):
            return
        kept = Mixture.of(
            self.config.detection * np.minimum(predicted_weights[rows], 1.0),
            self.states[rows],
            self.covariances[rows],
        )
        self.pending = Mixture.concatenate([self.pending, kept])

    def _note_exits(self) -> None:
        """Track which labels are inside an occlusion region; those that just left one open
        an `OcclusionExit`."""
        now = self.monitor.involved()
        for label in now - set(self._involved):
            self._involved[label] = self.book.next_id
        rows = {label: row for row, label in enumerate(self.book.ids.tolist())}
        for label in set(self._involved) - now:
            if label in rows:
                self._record_exit(rows[label], label)
            else:
                del self._involved[label]

    def _record_exit(self, row: int, label: int) -> None:
        first_id = self._involved.pop(label, self.book.next_id)
        if self.stitch_frames <= 0:
            return
        state, time = self._anchor(row)
        self.exits[label] = OcclusionExit(state.copy(), time, first_id, self.stitch_frames)

    def _stitch(self, t: float, lost: np.ndarray) -> None:
        """After an occlusion the blob's pieces may have gone to the wrong labels, or a hidden
        target come out as a new track; a lost track's target may be found again as a new one.
        For a few frames, each label that left an occlusion or lost its track goes to the track
        that best fits its dead reckoning (the kept speed and heading, with the spread of that
        guess): a Hungarian assignment between those labels and the tracks that carry them or
        were started since, outside occlusion regions; the tracks they displace take the labels
        they free."""
        if not self.exits:
            return
        labels = self.book.ids
        involved = set(self._involved)
        exits = [(e, x) for e, x in self.exits.items() if e not in involved]
        rows = [
            row
            for row, label in enumerate(labels.tolist())
            if not lost[row]
            and label not in involved
            and self.book.confirmed[row]
            and (label in self.exits or any(label >= x.first_id for _, x in exits))
        ]
        if exits and rows:
            costs = self._exit_costs(t, exits, np.array(rows))
            pairs, cols = assign(costs, self.label_gate)
            self._relabel([exits[i][0] for i in pairs], [rows[j] for j in cols])
        for label in list(self.exits):
            self.exits[label].frames_left -= 1
            if self.exits[label].frames_left <= 0:
                del self.exits[label]

    def _exit_costs(
        self, t: float, exits: list[tuple[int, OcclusionExit]], rows: np.ndarray
    ) -> np.ndarray:
        """(exits, rows) squared distances of the tracks' positions from the labels' dead
        reckoning over the guess's variance; barred for tracks started before the label's
        occlusion (they are other targets)."""
        positions = LAYOUT.positions(self.states)[rows]
        labels = self.book.ids[rows]
        r2 = self.config.measurement_noise**2
        costs = np.full((len(exits), len(rows)), BARRED)
        for i, (label, exit_) in enumerate(exits):
            predicted, variance = _dead_reckoning(exit_.state, t - exit_.time)
            spread = variance + 2.0 * r2
            allowed = (labels == label) | (labels >= exit_.first_id)
            squared = ((positions - predicted) ** 2).sum(axis=1) / spread
            costs[i] = np.where(allowed, squared, BARRED)
        return costs

    def _relabel(self, wanted: list[int], rows: list[int]) -> None:
        """Give each of `rows` the label in `wanted`; a track that carried one of those labels
        takes a label they freed (a new id when none is left)."""
        ids = self.book.ids
        taken = set(wanted)
        freed = [int(ids[row]) for row in rows if int(ids[row]) not in taken]
        displaced = [
            row for row, label in enumerate(ids.tolist()) if label in taken and row not in rows
        ]
        new = ids.copy()
        new[rows] = wanted
        for row in displaced:
            if freed:
                new[row] = freed.pop(0)
            else:
                new[row] = self.book.next_id
                self.book.next_id += 1
        for label in set(ids[ids != new].tolist()) | set(new[ids != new].tolist()):
            self.anchors.pop(label, None)
        self.book.ids = new

    def _begin_reckoned(
        self, t: float, labels: np.ndarray, positions: np.ndarray, hidden: np.ndarray
    ) -> list[int]:
        """Undetected tracks that had come near another (anchored) are judged hidden at their
        dead-reckoned positions too: the merging blobs may have pulled a track's state more
        than an object size off the blob that now hides its target. Returns the rows begun."""
        anchored = hidden & np.isin(labels, list(self.anchors))
        rows = np.flatnonzero(anchored)
        if not len(rows):
            return []
        reckoned = positions.copy()
        reckoned[rows] = self._since_hit(rows, t)[0][:, :2]
        return self.monitor.begin(labels, reckoned, anchored, self._epsilon_now)

    def _lost(self, bounds: tuple[float, float, float, float] | None) -> np.ndarray:
        occluded = np.array([label in self.monitor.occluded for label in self.book.ids.tolist()])
        occluded = occluded.astype(bool).reshape(-1)
        lost = np.where(
            occluded, self.unassigned > self.max_misses, self.book.misses > self.max_misses
        )
        for row in np.flatnonzero(lost):
            label = int(self.book.ids[row])
            if label not in self.monitor.occluded and self.book.confirmed[row]:
                position = self.book.measured[row]
                self.monitor.record_death(position, bounds, self._epsilon_now)
            if self.book.confirmed[row]:
                self._record_exit(int(row), label)
            self.monitor.forget(label)
        return lost

    def _start_tracks(
        self, t: float, estimates: Estimates, taken: np.ndarray, detections: Detections
    ) -> None:
        free = ~self._explained
        free[taken] = False
        used = set(estimates.sources[taken].tolist())
        new: list[int] = []
        for col in np.flatnonzero(free):
            source = int(estimates.sources[col])
            strong = estimates.weights[col] > self.config.extract_threshold
            if strong and source >= 0 and source not in used and estimates.tags[col] == 0:
                used.add(source)
                new.append(int(col))
        if not new:
            return
        cols = np.array(new)
        self.book.add(t, detections, estimates.sources[cols], np.zeros(len(cols), dtype=bool))
        rows = {
            "states": estimates.means[cols],
            "covariances": estimates.covariances[cols],
            "weights": estimates.weights[cols],
            "unassigned": np.zeros(len(cols), np.int64),
            "mean_velocities": estimates.means[cols][:, 2:],
            "mean_positions": detections.positions[estimates.sources[cols]],
            "history_times": np.column_stack(
                [np.full((len(cols), self.velocity_history - 1), np.nan), np.full(len(cols), t)]
            ),
            "history_points": np.repeat(
                detections.positions[estimates.sources[cols]][:, None, :],
                self.velocity_history,
                axis=1,
            ),
        }
        for name in _ROW_FIELDS:
            setattr(self, name, np.concatenate([getattr(self, name), rows[name]]))

    def _drop(self, lost: np.ndarray) -> None:
        if not lost.any():
            return
        keep = ~lost
        for label in self.book.ids[lost].tolist():
            self.anchors.pop(label, None)
        self.book.keep(keep)
        for name in _ROW_FIELDS:
            setattr(self, name, getattr(self, name)[keep])


METHOD: Method[Any] = Method.of(
    name="gm_phd",
    description="Gaussian-mixture PHD filter (Vo & Ma) with occlusion regions, persistence and "
    "Hungarian labelling (seed 004)",
    config=GmPhdTrackerConfig,
    make=GmPhdTracker,
    warm_up=gmphd.warm_up,
)
