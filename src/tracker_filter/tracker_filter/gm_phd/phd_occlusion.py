"""Seed 004's occlusion handling around a GM-PHD filter (no rclpy).

The thesis's three kinds of region, as `OcclusionMonitor` keeps them per labelled track:

1. possible-occlusion circle: radius epsilon (the mean object size of the frame) around each track;
2. occlusion region: a confirmed track that stops being detected inside another track's circle
   (E(x_i, x_j) = 1: ||x_i - x_j|| <= epsilon and one of them lost its measurement) is occluded,
   the region centred between the two (a track missed elsewhere is not kept alive: under heavy
   clutter a kept-alive track is soon re-"detected" by a false alarm and never dies);
3. occlusion region with an unidentified object: where tracks died suddenly away from the view's
   borders; deaths close together enlarge one region. A track that stops being detected inside
   such a region is occluded too (a static object hides it), and the region gets a birth
   Gaussian, so a target that reappears there is picked up at once.

The visible partner of an occlusion (the track whose blob hides the other) gets such a Gaussian
too, beside the blob's: when the blob splits, the blob's Gaussian follows the nearest piece,
the dead-reckoned one the piece that moved as the partner did.

An occluded track keeps its Gaussian: a component at its state predicted from its last hit with
its mean velocity is injected, tagged with the track's label (so it is never merged into the
Gaussian of the target hiding it; m = F m~, P = F P~ F^T + Q through the filter's prediction). It
is guarded (the measurement a visible target explains best -- the blob of the target that hides
it -- does not update it), its missed-detection term is multiplied by the persistence factor
P_d^occl instead of 1 - p_D, and its p_D is 1 - P_d^occl. P_d^occl is 1 when the occlusion
starts and drops by chi = 0.3 / N_occ per occluded frame down to `floor` (0.7), N_occ being the
mean occlusion length in frames seen so far (`mean_occlusion` until one has ended). This is the
digest's reading of the thesis's adaptive detection probability (a literal p_D = 1 would zero
the missed-detection term, the opposite of the intent).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tracker_filter.gm_phd.gmphd import DIM, DetectionTerms, Mixture

AXES = 2


@dataclass(frozen=True)
class OcclusionConfig:
    enabled: bool = True
    drop: float = 0.3  # chi = drop / N_occ per occluded frame
    floor: float = 0.7  # P_d^occl never below this
    mean_occlusion: float = 5.0  # frames, N_occ before any occlusion has ended
    object_size: float = 20.0  # px, epsilon when a frame has no measured sizes
    border_margin: float = 20.0  # px, deaths nearer the view's border are departures
    region_birth_weight: float = 0.02  # weight of the birth Gaussian at an unidentified object
    max_regions: int = 50  # unidentified-object regions kept (oldest forgotten first)

    def problems(self) -> list[str]:
        found = []
        if not 0.0 < self.floor <= 1.0:
            found.append(f"floor must be in (0, 1], got {self.floor}")
        if not self.drop >= 0.0:
            found.append(f"drop must be >= 0, got {self.drop}")
        if not self.mean_occlusion >= 1.0:
            found.append(f"mean_occlusion must be >= 1 frame, got {self.mean_occlusion}")
        for name in ("object_size", "border_margin", "region_birth_weight"):
            if not getattr(self, name) >= 0.0:
                found.append(f"{name} must be >= 0, got {getattr(self, name)}")
        return found


@dataclass
class Occlusion:
    """One occluded track: where it was hidden, for how long, its persistence factor."""

    centre: np.ndarray  # (2,) px, the occlusion region's centre
    radius: float  # px
    partner: int = 0  # label of the track whose blob hides it (0: an unidentified object)
    frames: int = 0
    persistence: float = 1.0  # P_d^occl


@dataclass
class UnknownObjectRegion:
    """Where tracks died away from the borders: something unseen hides targets there."""

    centre: np.ndarray
    radius: float
    deaths: int = 1


@dataclass
class OcclusionMonitor:
    """The occlusion state of every labelled track; see the module docstring."""

    config: OcclusionConfig = field(default_factory=OcclusionConfig)
    occluded: dict[int, Occlusion] = field(default_factory=dict)  # by track label
    regions: list[UnknownObjectRegion] = field(default_factory=list)
    ended: list[int] = field(default_factory=list)  # lengths (frames) of occlusions that ended

    def reset(self) -> None:
        self.occluded.clear()
        self.regions.clear()
        self.ended.clear()

    @property
    def mean_length(self) -> float:
        """N_occ, frames."""
        return float(np.mean(self.ended)) if self.ended else self.config.mean_occlusion

    def detection_terms(self, tags: np.ndarray, detection: float) -> DetectionTerms:
        """Per component: those of an occluded track and of its partner (the dead-reckoned
        Gaussian kept beside the blob the partner follows) are guarded, missed-detection factor
        P_d^occl and p_D = 1 - P_d^occl; the others p_D (`detection`) and 1 - p_D."""
        terms = DetectionTerms.standard(len(tags), detection)
        for label, occlusion in self.occluded.items():
            for owner in (label, occlusion.partner) if occlusion.partner else (label,):
                mine = tags == owner
                terms.miss[mine] = np.maximum(
                    np.where(terms.guarded[mine], terms.miss[mine], 0.0), occlusion.persistence
                )
                terms.detection[mine] = 1.0 - terms.miss[mine]
                terms.guarded[mine] = True
        return terms

    def _in_region(self, position: np.ndarray) -> UnknownObjectRegion | None:
        for region in self.regions:
            if np.hypot(*(position - region.centre)) <= region.radius:
                return region
        return None

    def begin(
        self,
        labels: np.ndarray,
        positions: np.ndarray,
        hidden: np.ndarray,
        epsilon: float,
    ) -> list[int]:
        """Tracks (rows) of `hidden` (confirmed, not detected this frame) that are occluded from
        now on: by another target when inside its possible-occlusion circle, by an unidentified
        object inside such a region. Returns their rows."""
        if not self.config.enabled:
            return []
        begun = []
        for row in np.flatnonzero(hidden):
            label = int(labels[row])
            if label in self.occluded:
                continue
            gaps = np.hypot(*(positions - positions[row]).T)
            gaps[row] = np.inf
            # the blob that hides it is a visible track's: prefer those to other hidden ones
            ranked = gaps + np.where(hidden, epsilon, 0.0)
            near = int(np.argmin(ranked)) if len(gaps) > 1 else -1
            if near >= 0 and gaps[near] <= epsilon:
                centre = (positions[row] + positions[near]) / 2.0
                radius = max(epsilon, float(gaps[near]))
                self.occluded[label] = Occlusion(centre, radius, int(labels[near]))
            elif (region := self._in_region(positions[row])) is not None:
                self.occluded[label] = Occlusion(region.centre.copy(), region.radius)
            else:
                continue
            begun.append(int(row))
        return begun

    def partners(self) -> set[int]:
        """Labels of the visible tracks whose blobs hide an occluded one: inside the occlusion
        region too, their own measurements are merged blobs until the hidden one is back."""
        return {o.partner for o in self.occluded.values() if o.partner}

    def involved(self) -> set[int]:
        """Labels inside an occlusion region: the occluded tracks and their visible partners."""
        return set(self.occluded) | self.partners()

    def away_from_border(
        self, position: np.ndarray, window: tuple[float, float, float, float] | None
    ) -> bool:
        """True when `position` is `border_margin` inside the view (`window` x, y, width, height;
        None: the view is unknown, so nothing is at its border)."""
        if window is None:
            return True
        x, y, width, height = window
        margin = self.config.border_margin
        return bool(
            (x + margin <= position[0] <= x + width - margin)
            and (y + margin <= position[1] <= y + height - margin)
        )

    def advance(self, labels: np.ndarray, hit: np.ndarray) -> list[int]:
        """One more frame: occluded tracks detected again end their occlusion (their labels are
        returned, so their components lose the tag); the others lose persistence."""
        chi = self.config.drop / self.mean_length
        back = []
        for label, hidden in zip(labels.tolist(), hit.tolist(), strict=True):
            occlusion = self.occluded.get(label)
            if occlusion is None:
                continue
            if hidden:
                self.ended.append(max(occlusion.frames, 1))
                del self.occluded[label]
                back.append(label)
            else:
                occlusion.frames += 1
                occlusion.persistence = max(occlusion.persistence - chi, self.config.floor)
        return back

    def forget(self, label: int) -> None:
        """The track is gone (lost): its occlusion, if any, ends unresolved."""
        self.occluded.pop(label, None)

    def record_death(
        self, position: np.ndarray, window: tuple[float, float, float, float] | None, epsilon: float
    ) -> bool:
        """A track died at `position` without an occlusion: away from the view's borders
        (`window` x, y, width, height; None: unknown, so not recorded) it marks an unidentified
        object. True when recorded."""
        if not self.config.enabled or window is None or not self.away_from_border(position, window):
            return False
        for region in self.regions:
            gap = float(np.hypot(*(position - region.centre)))
            if gap <= region.radius + epsilon:
                region.deaths += 1
                weight = 1.0 / region.deaths
                region.centre = (1.0 - weight) * region.centre + weight * position
                region.radius = max(region.radius, gap * (1.0 - weight) + epsilon)
                return True
        self.regions.append(UnknownObjectRegion(np.array(position, dtype=float), epsilon))
        del self.regions[: max(0, len(self.regions) - self.config.max_regions)]
        return True

    def region_births(self, measurement_noise: float, speed_std: float) -> Mixture:
        """A birth Gaussian (still, any direction) at every unidentified-object region."""
        count = len(self.regions)
        if not count or self.config.region_birth_weight <= 0:
            return Mixture.empty()
        means = np.zeros((count, DIM))
        covariances = np.zeros((count, DIM, DIM))
        for i, region in enumerate(self.regions):
            means[i, :AXES] = region.centre
            spread = max(region.radius, measurement_noise) ** 2
            covariances[i] = np.diag([spread, spread, speed_std**2, speed_std**2])
        return Mixture.of(np.full(count, self.config.region_birth_weight), means, covariances)
