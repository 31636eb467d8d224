"""Seed 004's multi-target tracker: GM-PHD filter, occlusion handling, Hungarian labels (no rclpy).

A `tracking.Tracker` (method `gm_phd`). Each frame:
1. `gmphd.GmPhdFilter` steps on the detections' centroids; occluded tracks' Gaussians are kept
   alive by `phd_occlusion.OcclusionMonitor` (tags, injection, persistence factor), and every
   unidentified-object region adds a birth Gaussian;
2. the extracted states are labelled by `phd_labels` (Hungarian on Mahalanobis cost, impulse);
   extracted states that no track takes and that come from a measurement no track used start new
   tracks;
3. a track is a hit when its state came from a measurement no better-matching track used; a
   track not hit inside another's possible-occlusion circle, or inside an unidentified-object
   region, becomes occluded; an occluded track hit again ends its occlusion;
4. bookkeeping by `tracking.TrackBook`: confirmed after `confirm_hits` hits, LOST after more than
   `max_misses` frames without a state of its own (without a hit, when it is not occluded); a
   confirmed track lost without an occlusion away from the view's borders marks an unidentified
   object there.

Layout "x y vx vy" (px, px/s); `existence` is the weight of the track's Gaussian (at most 1).
The camera window gives the view's borders and, with `area` 0, the clutter density's area; a
frame without it still updates every track.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from tracker_filter.gmphd import Estimates, GmPhdConfig, GmPhdFilter, Mixture
from tracker_filter.layout import StateLayout
from tracker_filter.models import CONSTANT_VELOCITY
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.phd_labels import BARRED, LabelledStates, assign, labelling_costs
from tracker_filter.phd_occlusion import OcclusionConfig, OcclusionMonitor
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.params import ParamSpec
from tracker_msgs_py.registry import Method

LAYOUT = StateLayout.from_names("x y vx vy")
FIRST_INTERVAL = 1.0  # s, the first frame's (nothing to predict yet)


def _one_per_tag(estimates: Estimates) -> np.ndarray:
    """Mask of the estimates labelling may use: every untagged one, and of each occluded track's
    (tagged) estimates the one a measurement made, else the heaviest."""
    usable = estimates.tags == 0
    for tag in np.unique(estimates.tags[~usable]):
        mine = np.flatnonzero(estimates.tags == tag)
        rank = (estimates.sources[mine] >= 0) * 2.0 + np.minimum(estimates.weights[mine], 1.0)
        usable[mine[np.argmax(rank)]] = True
    return usable


class GmPhdTracker:
    """GM-PHD with seed 004's occlusion handling and labelling, as a `tracking.Tracker`."""

    needs = frozenset({Need.WINDOW})
    layout = LAYOUT

    def __init__(
        self,
        filter_config: GmPhdConfig,
        occlusion: OcclusionConfig,
        label_gate: float = 16.0,
        impulse: float = 0.5,
        confirm_hits: int = 2,
        max_misses: int = 3,
        window_area: bool = False,
        continue_threshold: float = 0.2,
        first_id: int = 1,
    ) -> None:
        self.config = filter_config
        self.filter = GmPhdFilter(filter_config)
        self.monitor = OcclusionMonitor(occlusion)
        self.label_gate, self.impulse = label_gate, impulse
        self.confirm_hits, self.max_misses = confirm_hits, max_misses
        self.window_area = window_area
        self.continue_threshold = continue_threshold
        self.book = TrackBook(first_id)
        self._clear()

    def _clear(self) -> None:
        self.states = np.zeros((0, LAYOUT.dim))
        self.covariances = np.zeros((0, LAYOUT.dim, LAYOUT.dim))
        self.weights = np.zeros(0)
        self.unassigned = np.zeros(0, np.int64)  # consecutive frames without a state of its own
        self.pending = Mixture.empty()  # Gaussians of tracks occluded at the last frame
        self._epsilon_now = self.monitor.config.object_size  # px, this frame's occlusion radius
        self._explained: np.ndarray = np.zeros(0, dtype=bool)  # per estimate: within a track's gate

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

    def _label(self, estimates: Estimates) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Assigned rows and estimate columns, and per row whether its state is a hit; marks
        in `self._explained` the estimates an existing track could have taken (within the gate
        of one): they never start a track (the PHD update gives a clutter point near a target
        almost the target's whole weight; that is one target, not two)."""
        centres = np.full((len(self.book), 2), np.nan)
        for row, label in enumerate(self.book.ids.tolist()):
            if label in self.monitor.occluded:
                centres[row] = self.monitor.occluded[label].centre
        tracks = LabelledStates(self.book.ids, self.states[:, :2], self.states[:, 2:], centres)
        costs = labelling_costs(tracks, estimates, self.config.measurement_noise**2, self.impulse)
        costs[:, ~_one_per_tag(estimates)] = BARRED
        self._explained = np.asarray((costs <= self.label_gate).any(axis=0))
        rows, cols = assign(costs, self.label_gate)
        hit = np.zeros(len(self.book), dtype=bool)
        sources = estimates.sources[cols]
        # a measurement shared by several tracks (a merged blob) is the hit of the nearest only
        for source in np.unique(sources[sources >= 0]):
            sharing = np.flatnonzero(sources == source)
            best = sharing[np.argmin(costs[rows[sharing], cols[sharing]])]
            hit[rows[best]] = True
        return rows, cols, hit

    def step(self, observation: Observation) -> TrackSet:
        t, book = observation.time, self.book
        book.check_time(t)
        dt = t - book.time if book.time is not None else FIRST_INTERVAL
        detections, rejections = observation.detections.validated()
        self._adopt_window_area(observation)
        config = self.filter.config
        injected = Mixture.concatenate(
            [
                self.pending,
                self.monitor.region_births(config.measurement_noise, config.max_birth_speed / 2),
            ]
        )
        estimates = self.filter.step(
            detections.positions,
            dt,
            injected,
            lambda predicted: self.monitor.miss_factors(predicted.tags, 1.0 - config.detection),
            min(self.continue_threshold, config.extract_threshold),
        )
        # every track predicted to t (coasting); those given a state take it below
        transition = CONSTANT_VELOCITY.transition(dt)
        noise = CONSTANT_VELOCITY.process_noise(dt, config.process_noise)
        self.states = self.states @ transition.T
        self.covariances = transition @ self.covariances @ transition.T + noise
        self.weights = config.survival * self.weights
        rows, cols, hit = self._label(estimates)
        self.states[rows] = estimates.means[cols]
        self.covariances[rows] = estimates.covariances[cols]
        self.weights[rows] = estimates.weights[cols]
        self.unassigned += 1
        self.unassigned[rows] = 0
        self.weights[self.unassigned > 0] = 0.0  # no Gaussian of its own: a prediction
        hit_rows = np.flatnonzero(hit)
        sources = np.full(len(book), -1, np.int64)
        sources[rows] = estimates.sources[cols]
        book.record_frame(hit_rows, sources[hit_rows], detections, LAYOUT.positions(self.states))
        window = observation.window
        bounds = None if window is None else (window.x, window.y, window.width, window.height)
        self._occlusions(hit, detections.bboxes, bounds)
        lost = self._lost(bounds)
        count = len(book)
        self._start_tracks(t, estimates, cols, detections)
        added = len(book) - count
        lost = np.concatenate([lost, np.zeros(added, dtype=bool)])
        updated = np.concatenate([hit, np.ones(added, dtype=bool)])
        book.confirm(book.hits >= self.confirm_hits)
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

    def _occlusions(
        self, hit: np.ndarray, boxes: np.ndarray, bounds: tuple[float, float, float, float] | None
    ) -> None:
        labels = self.book.ids
        for label in self.monitor.advance(labels, hit):
            mixture = self.filter.mixture
            tags = np.where(mixture.tags == label, 0, mixture.tags)
            self.filter.mixture = replace(mixture, tags=tags)
        self._epsilon_now = self._epsilon(boxes)
        hidden = ~hit & self.book.confirmed
        positions = LAYOUT.positions(self.states)
        begun = self.monitor.begin(labels, positions, hidden, self._epsilon_now)
        if begun:
            rows = np.array(begun)
            self.pending = Mixture.of(
                np.ones(len(rows)), self.states[rows], self.covariances[rows], labels[rows]
            )
            self.weights[rows] = np.maximum(self.weights[rows], 1.0)
        else:
            self.pending = Mixture.empty()

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
        self.states = np.concatenate([self.states, estimates.means[cols]])
        self.covariances = np.concatenate([self.covariances, estimates.covariances[cols]])
        self.weights = np.concatenate([self.weights, estimates.weights[cols]])
        self.unassigned = np.concatenate([self.unassigned, np.zeros(len(cols), np.int64)])

    def _drop(self, lost: np.ndarray) -> None:
        if not lost.any():
            return
        keep = ~lost
        self.book.keep(keep)
        self.states, self.covariances = self.states[keep], self.covariances[keep]
        self.weights, self.unassigned = self.weights[keep], self.unassigned[keep]


_F = GmPhdConfig()
_O = OcclusionConfig()
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("survival", _F.survival, "p_S, survival probability per frame", 0.01, 1.0),
    ParamSpec("detection", _F.detection, "p_D, detection probability", 0.01, 1.0),
    ParamSpec("clutter_rate", 5.0, "lambda_c, false detections per frame", 0.0, 1e6),
    ParamSpec(
        "area", 0.0, "px^2 the clutter spreads over (0: the camera window's area)", 0.0, 1e12
    ),
    ParamSpec("process_noise", 150.0, "sigma_v, acceleration noise [px/s^2]", 1e-3, 1e6),
    ParamSpec("measurement_noise", 3.0, "sigma_r, centroid noise [px]", 1e-3, 1e4),
    ParamSpec("prune_threshold", _F.prune_threshold, "T, components lighter are dropped", 0.0, 1.0),
    ParamSpec(
        "merge_threshold", _F.merge_threshold, "U, squared Mahalanobis merge distance", 0.0, 1e4
    ),
    ParamSpec("max_components", 500, "J_max, Gaussians kept at most", 1, 100000),
    ParamSpec(
        "extract_threshold", _F.extract_threshold, "a Gaussian heavier is a target", 0.01, 1.0
    ),
    ParamSpec(
        "birth_weight", _F.birth_weight, "weight of the births one detection makes", 0.0, 1.0
    ),
    ParamSpec("max_birth_speed", 400.0, "px/s between the two detections of a birth", 1e-3, 1e6),
    ParamSpec(
        "birth_gate",
        _F.birth_gate,
        "a detection explained this well by targets births none",
        0.01,
        1.0,
    ),  # fmt: skip
    ParamSpec("spawn_weight", _F.spawn_weight, "spawned Gaussians per target (0: none)", 0.0, 1.0),
    ParamSpec("occlusion_handling", _O.enabled, "seed 004's occlusion regions and persistence"),
    ParamSpec("persistence_floor", _O.floor, "P_d^occl never below this", 0.01, 1.0),
    ParamSpec(
        "mean_occlusion", _O.mean_occlusion, "frames an occlusion lasts until one is seen", 1.0, 1e4
    ),
    ParamSpec("object_size", _O.object_size, "px, occlusion radius without sized boxes", 0.0, 1e4),
    ParamSpec(
        "border_margin",
        _O.border_margin,
        "px, deaths this near the view's edge are exits",
        0.0,
        1e4,
    ),  # fmt: skip
    ParamSpec("label_gate", 16.0, "squared Mahalanobis distance a label reaches", 0.1, 1e6),
    ParamSpec("impulse", 0.5, "cost factor of candidates ahead of an occluded track", 0.0, 1.0),
    ParamSpec("confirm_hits", 2, "hits before a track is confirmed", 1, 1000),
    ParamSpec("max_misses", 3, "frames without its own state after which a track is lost", 0, 1000),
)


def build(values: Mapping[str, Any], first_id: int = 1) -> GmPhdTracker:
    area = float(values["area"])
    filter_config = GmPhdConfig(
        survival=values["survival"],
        detection=values["detection"],
        clutter_rate=values["clutter_rate"],
        area=area if area > 0 else 640.0 * 480.0,
        process_noise=values["process_noise"],
        measurement_noise=values["measurement_noise"],
        prune_threshold=values["prune_threshold"],
        merge_threshold=values["merge_threshold"],
        max_components=values["max_components"],
        extract_threshold=values["extract_threshold"],
        birth_weight=values["birth_weight"],
        max_birth_speed=values["max_birth_speed"],
        birth_gate=values["birth_gate"],
        spawn_weight=values["spawn_weight"],
    )
    occlusion = OcclusionConfig(
        enabled=values["occlusion_handling"],
        floor=values["persistence_floor"],
        mean_occlusion=values["mean_occlusion"],
        object_size=values["object_size"],
        border_margin=values["border_margin"],
    )
    problems = filter_config.problems() + occlusion.problems()
    if problems:
        raise ValueError("gm_phd: " + "; ".join(problems))
    return GmPhdTracker(
        filter_config,
        occlusion,
        label_gate=values["label_gate"],
        impulse=values["impulse"],
        confirm_hits=values["confirm_hits"],
        max_misses=values["max_misses"],
        window_area=area <= 0,
        continue_threshold=values["continue_threshold"],
        first_id=first_id,
    )


METHOD: Method[Any] = Method(
    name="gm_phd",
    description="Gaussian-mixture PHD filter (Vo & Ma) with occlusion regions, persistence and "
    "Hungarian labelling (seed 004)",
    build=build,
    parameters=PARAMETERS,
)
