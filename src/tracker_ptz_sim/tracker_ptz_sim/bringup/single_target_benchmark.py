"""single_target_benchmark: seed 001's CamShift and seed 003's particle filter on the benchmark's
scenes of real people (development and held-out, pooled apart), one person at a time.

    single_target_benchmark                       every real-people preset x 2 seeds, every variant
    single_target_benchmark --scenes walkers groups --seeds 3    the drawn figures
    single_target_benchmark --scenes walkers --seeds 1
    single_target_benchmark --runs 10             particle filters 10 times (sigma_Q)
    single_target_benchmark --sweep --runs 3      particle count and histogram bins
    single_target_benchmark --variants camshift   only the rows named
    single_target_benchmark --first-seed 3        three other scenes per preset

Protocol: for every person of a scene, each tracker is started on the person's true box in the
first frame where they are at least 90 % visible and 40 px tall (as a user would draw it) and runs
to the person's last frame on the fixed, whole-scene camera. Scored as seed 003 scores its trackers
(`evaluation.single_target`) over the frames where the person is in the ground truth and visible
enough to be scored: Q1 mean IoU, Q2 share of centres in the 0.8 x shorter-side square, success
share at IoU >= 0.5. Variants: CamShift with the thesis's plain hue histogram; CamShift with the
suite's background-weighted histogram (the default), alone (each search starts at the last window,
as in the thesis) and with its search window placed at the one-step prediction of seed 001's
nominal or robust (exact lambda) Kalman filter (the thesis's future work). Seed 003's colour
particle filter (750 particles, K = 16; its random generator seeded by the person's id) as the rows
of its thesis's algorithm table: baseline, Ext 1 sigmoid, Ext 3 HSV, Ext 5 region covariance, final
(Ext 1 + Ext 2); then the final algorithm with 8 x the thesis's noise, alone, with a
background-weighted reference, coasting through occlusions as well, and with a scale cue on top:
the contrast cue (`contrast` 1), or the foreground cue (`foreground_cue`: the motion mask of the
surveillance graph's detector, run over the scene, with the box's size free to move, `size_noise`),
and both cues with a prior on the box's height where it stands (`height_spread`: the ground line
the surveillance graph's tracker learns over the scene, by each frame, scaled through the person's
start box), that with 16 x the noise, and that coasting with a quarter of its randomness while the
person is hidden (`coast_noise`), that found again where the mask moves (`probes`,
`reappear_in_mask`), and the last two with the reported box pulled half-way to the box of the
mask's blobs it holds (`foreground_fit` 0.5; the first of them the colour_particles tracker's
defaults), and that with its box held no wider than one person usually is for their height
(`aspect_spread`; the tracker's default since 2026-11-28), and that never taken as hidden in its
first second (`settle_frames` 10; not the tracker's default: in the graph it made `occluded`
worse), and that with a hidden person's boxes rescaled by the ground line as they coast
(`coast_perspective`; the tracker's default since 2026-11-28), and that expecting the person's
start height until a ground line is learned (`height_before_line`), and that followed by the
top of its box on a frame it would be taken as hidden while only that part matches
(`upper_share`: someone behind a low board shows head and shoulders). With --runs R every
particle filter runs R times per person with different seeds (person id + 1000 r) and the table
gives the mean over runs and sigma_Q, the standard deviation of a run's Q over the runs (the
thesis's 10 runs). --sweep runs instead the best particle filter with 100 / 500 / 750 / 2000
particles and K = 8 / 16 / 32 bins per channel.

The "occluded" presets, where each person walks behind a board for 1 s, are watched by a moving
camera: a 480x360 window aimed at the person as a camera operator would (0.7 s lag, 12 px sway;
`evaluation.single_target.operator_path`), so the trackers see the scene move; its boxes are
scored in that window. "kept" counts the occlusions after which the estimate is back on the person
(its centre in Q2's square in most of the next 20 scored frames); under the table, per variant,
how many occlusions are kept in at least 90 % of the runs, and the runs kept of each that is not.

Writes to --out (default out/single_target): table.md, results.json and per scene iou-<scene>.png
(IoU over time per person and variant).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from tracker_detect.camshift.camshift import CamShiftConfig
from tracker_detect.detector import CameraFrame
from tracker_detect.detectors import DETECTORS
from tracker_filter.colour_histograms import ColourSpace
from tracker_filter.filters import FilterFactory
from tracker_filter.models import seed001_nominal_model
from tracker_filter.object_scale import HeightByRow
from tracker_filter.observation import Observation
from tracker_filter.particles.colour_particle import (
    RECOMMENDED_SIGMA,
    Appearance,
    CovarianceAppearance,
    HistogramAppearance,
    ParticleFilterConfig,
    WeightCorrection,
)
from tracker_filter.particles.foreground_cue import ForegroundCue
from tracker_filter.particles.particle_tracker import (
    ASPECT_SPREAD,
    COAST_NOISE,
    FOREGROUND_FIT,
    FOREGROUND_POWER,
    HEIGHT_SPREAD,
    NOISE_SCALE,
    OCCLUSION_RATIO,
    SETTLE_FRAMES,
    SIZE_NOISE,
    UPPER_SHARE,
)
from tracker_filter.robust_kalman import LambdaRule, RobustKalmanConfig, seed001_uncertainty
from tracker_filter.trackers import TRACKERS
from tracker_filter.tracking import TrackStatus
from tracker_msgs_py.codec import NS_PER_S
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.bringup.benchmark import RealPeople, background_image, prepare_scene
from tracker_ptz_sim.bringup.graph import load_graph
from tracker_ptz_sim.bringup.pipeline import PipelineSettings, detections_of
from tracker_ptz_sim.evaluation.prediction_study import PRIOR_STD
from tracker_ptz_sim.evaluation.scoring import write_json
from tracker_ptz_sim.evaluation.single_target import (
    GroundLines,
    SingleTargetScores,
    WindowedFrames,
    follow,
    follow_particles,
    kept_through_gaps,
    operator_path,
    pooled,
    score_single_target,
)
from tracker_ptz_sim.simulation import street
from tracker_ptz_sim.simulation.scene_files import load_scene
from tracker_ptz_sim.simulation.scenes import Scene

#: the thesis's plain hue histogram, without the suite's colour checks (the thesis has none:
#: with them most people's selections are refused, as their hues do not stand out)
THESIS = CamShiftConfig(background_weighting=False, min_similarity=0.0, min_contrast=0.0)


Boxes = dict[int, Rect | None]


@dataclass(frozen=True)
class Footage:
    """What a tracker is given: the camera's frames (indexed by scene frame), stamps and rate, the
    motion detector's foreground mask of each frame (for the particle filter's foreground cue)
    and the ground line the suite's tracker has learned by each frame (for its height prior);
    for a moving camera, where each frame's window lies in the scene (its top-left, scene px)."""

    frames: Sequence[np.ndarray] | np.ndarray
    stamps_ns: list[int]
    fps: float
    masks: Sequence[np.ndarray] | None = None
    ground: GroundLines | None = None
    origins: Mapping[int, tuple[int, int]] | None = None


@dataclass(frozen=True)
class Variant:
    """CamShift with a histogram configuration and the filter placing its search window."""

    camshift: CamShiftConfig
    rule: LambdaRule | None  # the filter placing the search window; None: the last window
    random: ClassVar[bool] = False
    needs_motion: ClassVar[bool] = False

    def run(self, footage: Footage, start: int, region: Rect, last: int, seed: int) -> Boxes:
        guide = predictor(self.rule, footage.fps)
        return follow(footage.frames, footage.stamps_ns, start, region, last, guide, self.camshift)


@dataclass(frozen=True)
class ParticleVariant:
    """Seed 003's particle filter with one appearance and configuration."""

    appearance: Callable[[], Appearance]
    config: ParticleFilterConfig
    # told where a moving camera's window is (the graph's PTZ pose); else it sees only images
    posed: bool = False
    random: ClassVar[bool] = True

    @property
    def needs_motion(self) -> bool:
        """Whether it needs the motion detector's masks or the ground line."""
        return self.config.foreground.enabled or self.config.height_spread > 0

    def run(self, footage: Footage, start: int, region: Rect, last: int, seed: int) -> Boxes:
        masks = footage.masks if self.config.foreground.enabled else None
        ground = footage.ground if self.config.height_spread > 0 else None
        appearance = self.appearance()
        origins = footage.origins if self.posed else None
        return follow_particles(
            footage.frames,
            start,
            region,
            last,
            appearance,
            self.config,
            seed,
            masks,
            ground,
            origins,
        )


BASELINE = ParticleFilterConfig(correction=WeightCorrection.NONE, adaptive_noise=False)
WIDE = ParticleFilterConfig(sigma=tuple(8 * s for s in RECOMMENDED_SIGMA))
COASTING = replace(WIDE, occlusion_ratio=OCCLUSION_RATIO)
FOREGROUND = replace(
    COASTING, size_noise=SIZE_NOISE, foreground=ForegroundCue(power=FOREGROUND_POWER)
)
HEIGHT = replace(FOREGROUND, height_spread=HEIGHT_SPREAD)
NOISIER = replace(HEIGHT, sigma=tuple(NOISE_SCALE * s for s in RECOMMENDED_SIGMA))
SHIPPED = replace(NOISIER, coast_noise=COAST_NOISE)
#: ... found again where the motion mask moves: 100 probes within one body height (200 land on
#: passers-by), back only in the mask; not the colour_particles tracker's defaults (in the graph
#: the probes made `occluded` worse)
PROBING = replace(SHIPPED, probes=100, probe_reach=1.0, reappear_in_mask=True)
#: ... the reported box half-way to the box of the mask's blobs it holds (`foreground_fit`; the
#: colour_particles tracker's defaults since 2026-11-27)
FITTED = replace(SHIPPED, foreground=replace(SHIPPED.foreground, fit=FOREGROUND_FIT))
PROBING_FITTED = replace(PROBING, foreground=FITTED.foreground)
#: ... and a box held from growing wider than one person usually is for their height
#: (`aspect_spread`; the colour_particles tracker's default since 2026-11-28)
SHAPED = replace(PROBING_FITTED, aspect_spread=ASPECT_SPREAD)
#: ... and never taken as hidden in its first second (`settle_frames`; not the colour_particles
#: tracker's default: in the graph it made `occluded` and `shaky` worse)
SETTLED = replace(SHAPED, settle_frames=SETTLE_FRAMES)
#: ... and a hidden target's boxes shrinking or growing with the ground line as they coast
PERSPECTIVE = replace(SETTLED, coast_perspective=True)
#: ... and, until the suite has learned a ground line, the target's start height expected
BEFORE_LINE = replace(PERSPECTIVE, height_before_line=True)
#: ... and a target seen only in part followed by the top of its box (`upper_share`)
UPPER = replace(BEFORE_LINE, upper_share=UPPER_SHARE)


def contrasted() -> HistogramAppearance:
    """The background-weighted histogram with the contrast scale cue (`contrast` 1)."""
    return HistogramAppearance(background_weighting=True, contrast=1.0)


#: the name of the rows from quiet coasting on, before what each adds
QUIET = (
    "particles, final, 16 x sigma, background-weighted, quiet coasting, contrast, "
    "foreground, height"
)
#: What is compared: one line per variant.
VARIANTS: dict[str, Variant | ParticleVariant] = {
    "camshift, thesis histogram": Variant(THESIS, None),
    "camshift": Variant(CamShiftConfig(), None),
    "camshift + nominal": Variant(CamShiftConfig(), LambdaRule.NOMINAL),
    "camshift + robust": Variant(CamShiftConfig(), LambdaRule.EXACT),
    "particles, baseline": ParticleVariant(HistogramAppearance, BASELINE),
    "particles, ext 1 sigmoid": ParticleVariant(
        HistogramAppearance, replace(BASELINE, correction=WeightCorrection.SIGMOID)
    ),
    "particles, ext 3 hsv": ParticleVariant(lambda: HistogramAppearance(ColourSpace.HSV), BASELINE),
    "particles, ext 5 covariance": ParticleVariant(CovarianceAppearance, BASELINE),
    "particles, final (ext 1 + 2)": ParticleVariant(HistogramAppearance, ParticleFilterConfig()),
    # not the thesis's: its sigma suits ~1 px per frame (CAVIAR at 25 fps), these people walk
    # 4-8 px per frame at 10 fps; and a person's box is mostly background, so the coefficients
    # of every box near them are 0.7-0.9 unless the reference is background-weighted
    "particles, final, 8 x sigma": ParticleVariant(HistogramAppearance, WIDE),
    "particles, final, 8 x sigma, background-weighted": ParticleVariant(
        lambda: HistogramAppearance(background_weighting=True), WIDE
    ),
    # ... and coasting through occlusions
    "particles, final, 8 x sigma, background-weighted, coasting": ParticleVariant(
        lambda: HistogramAppearance(background_weighting=True), COASTING
    ),
    # ... with a scale cue: the ring around a box must not look like the person
    "particles, final, 8 x sigma, background-weighted, coasting, contrast": ParticleVariant(
        contrasted, COASTING
    ),
    # ... or with the motion detector's mask as the scale cue, the size free to follow it
    "particles, final, 8 x sigma, background-weighted, coasting, foreground": ParticleVariant(
        lambda: HistogramAppearance(background_weighting=True), FOREGROUND
    ),
    # ... and both cues
    "particles, final, 8 x sigma, background-weighted, coasting, contrast, foreground": (
        ParticleVariant(contrasted, FOREGROUND)
    ),
    # ... and a prior on the box's height where it stands
    "particles, final, 8 x sigma, background-weighted, coasting, contrast, foreground, height": (
        ParticleVariant(contrasted, HEIGHT)
    ),
    # ... with twice the noise
    "particles, final, 16 x sigma, background-weighted, coasting, contrast, foreground, height": (
        ParticleVariant(contrasted, NOISIER)
    ),
    # ... coasting with a quarter of that randomness
    QUIET: ParticleVariant(contrasted, SHIPPED),
    # ... and found again where the detector's mask moves (probes; back only in the mask)
    f"{QUIET}, probes": ParticleVariant(contrasted, PROBING),
    # the last two with the reported box pulled toward the mask's blobs
    f"{QUIET}, fitted": ParticleVariant(contrasted, FITTED),
    f"{QUIET}, probes, fitted": ParticleVariant(contrasted, PROBING_FITTED),
    # the same told the moving camera's pose, as the graph's tracker is (fixed camera: the same)
    f"{QUIET}, probes, fitted, camera pose": ParticleVariant(
        contrasted, PROBING_FITTED, posed=True
    ),
    # ... and no wider than one person usually is (the aspect prior)
    f"{QUIET}, probes, fitted, aspect": ParticleVariant(contrasted, SHAPED),
    f"{QUIET}, probes, fitted, aspect, camera pose": ParticleVariant(
        contrasted, SHAPED, posed=True
    ),
    # ... and never taken as hidden in its first second
    f"{QUIET}, probes, fitted, aspect, settled": ParticleVariant(contrasted, SETTLED),
    f"{QUIET}, probes, fitted, aspect, settled, camera pose": ParticleVariant(
        contrasted, SETTLED, posed=True
    ),
    # ... and coasting in perspective
    f"{QUIET}, probes, fitted, aspect, settled, perspective": ParticleVariant(
        contrasted, PERSPECTIVE
    ),
    f"{QUIET}, probes, fitted, aspect, settled, perspective, camera pose": ParticleVariant(
        contrasted, PERSPECTIVE, posed=True
    ),
    # ... and the start height expected before a ground line is learned
    f"{QUIET}, probes, fitted, aspect, settled, perspective, start height": ParticleVariant(
        contrasted, BEFORE_LINE
    ),
    f"{QUIET}, probes, fitted, aspect, settled, perspective, start height, camera pose": (
        ParticleVariant(contrasted, BEFORE_LINE, posed=True)
    ),
    # ... and followed by the top of its box while only that part matches
    f"{QUIET}, probes, fitted, aspect, settled, perspective, start height, upper part": (
        ParticleVariant(contrasted, UPPER)
    ),
    f"{QUIET}, probes, fitted, aspect, settled, perspective, start height, upper part, "
    "camera pose": ParticleVariant(contrasted, UPPER, posed=True),
}


def _best(particles: int = 750, bins: int = 16) -> ParticleVariant:
    """The sweep's filter: the best before the scale cues (final, 8 x sigma, background-weighted,
    coasting), on which docs/results/seed003.md's particle-count and bins table was measured."""
    return ParticleVariant(
        lambda: HistogramAppearance(bins=bins, background_weighting=True),
        replace(COASTING, particles=particles),
    )


#: --sweep: the thesis's particle-count and histogram-size tables, on the best particle filter.
SWEEP: dict[str, ParticleVariant] = {
    **{f"best, N = {n}": _best(particles=n) for n in (100, 500, 750, 2000)},
    **{f"best, K = {k}": _best(bins=k) for k in (8, 32)},
}
#: Every street preset by name: the scenes of real people (the default), then the drawn figures.
PRESETS = {**street.REAL_PEOPLE_PRESETS, **street.STREET_PRESETS}
#: Presets watched by a camera operator's moving window: the people passing behind boards.
MOVING_CAMERA = {name for name in PRESETS if name.split("_")[-1] == "occluded"}
#: The table's pooled groups beside each preset: the development and the held-out people.
PEOPLE_SETS = {"development": "real_", "held-out": "heldout_"}
FIXED_CAMERA = "fixed camera"  # the table's rows pooled over the other presets
WINDOW = (480, 360)  # px, that window
START_VISIBILITY = 0.9
START_HEIGHT = 40.0  # px


def predictor(rule: LambdaRule | None, fps: float) -> FilterFactory | None:
    """Seed 001's filter at the scene's frame interval (nominal = robust with lambda 0)."""
    if rule is None:
        return None
    model = seed001_nominal_model(1.0 / fps)
    return RobustKalmanConfig(model, seed001_uncertainty(), rule, 0.5, PRIOR_STD)


@dataclass(frozen=True)
class PersonRun:
    scene: str
    person: int
    variant: str
    start: int
    scores: SingleTargetScores
    iou: dict[int, float]  # per scored frame
    refused: str = ""  # why CamShift would not start on the person (every frame then missed)
    run: int = 0  # which of the --runs (a particle filter's seed)
    kept: tuple[bool, ...] = ()  # per occlusion: back on the person afterwards


def people(scene: Scene) -> dict[int, dict[int, Rect]]:
    """Each person's scored boxes: person id -> frame -> box (conf = 1 only)."""
    out: dict[int, dict[int, Rect]] = {}
    for boxes in scene.boxes:
        for b in boxes:
            if b.conf:
                out.setdefault(b.object_id, {})[b.frame] = Rect(b.x, b.y, b.width, b.height)
    return out


def start_frame(scene: Scene, person: int) -> int | None:
    """The first frame where `person` is well visible, tall enough and wholly in the image."""
    height, width = scene.frames.shape[1:3]
    for boxes in scene.boxes:
        for b in boxes:
            inside = b.x >= 0 and b.y >= 0 and b.x + b.width <= width and b.y + b.height <= height
            if (
                b.object_id == person
                and b.conf
                and b.visibility >= START_VISIBILITY
                and b.height >= START_HEIGHT
                and inside
            ):
                return b.frame
    return None


def run_scene(
    label: str,
    scene: Scene,
    variants: Mapping[str, Variant | ParticleVariant],
    runs: int = 1,
    moving: bool = False,
) -> list[PersonRun]:
    """Every variant on every person of `scene` (particle filters `runs` times), on the fixed
    whole-scene camera or, `moving`, on a camera operator's window aimed at each person."""
    out = []
    masks, ground = None, None
    if any(v.needs_motion for v in variants.values()):
        masks, ground = motion_cues(scene)
    whole = Footage(scene.frames, scene.stamps_ns(), scene.fps, masks, ground)
    for person, truth in sorted(people(scene).items()):
        start = start_frame(scene, person)
        if start is None or not any(k > start for k in truth):
            continue
        footage = whole
        if moving:
            footage, truth = windowed(scene, whole, truth, start)
        scored = {k: box for k, box in truth.items() if k > start}
        if not scored:
            continue
        for variant, setup in variants.items():
            for run in range(runs if setup.random else 1):
                out.append(
                    run_person(
                        label, person, variant, setup, footage, truth[start], scored, start, run
                    )
                )
    return out


def windowed(
    scene: Scene, footage: Footage, truth: dict[int, Rect], start: int
) -> tuple[Footage, dict[int, Rect]]:
    """The footage and true boxes of a camera operator's window aimed at this person."""
    height, width = scene.frames.shape[1:3]
    frames = range(start, max(truth) + 1)
    path = operator_path(truth, frames, (width, height), WINDOW, scene.fps)
    in_view = {k: path.to_view(k, box) for k, box in truth.items() if k in frames}
    boxes = {k: box for k, box in in_view.items() if box is not None}
    masks = None if footage.masks is None else WindowedFrames(footage.masks, path)
    ground = footage.ground
    if ground is not None:
        ground = replace(ground, top_rows={k: float(y) for k, (_, y) in path.origins.items()})
    seen = WindowedFrames(scene.frames, path)
    return replace(footage, frames=seen, masks=masks, ground=ground, origins=path.origins), boxes


def motion_cues(scene: Scene) -> tuple[list[np.ndarray], GroundLines]:
    """The surveillance graph's motion stage (its detector and tracker, as configured there) run
    over `scene` on the fixed whole-scene camera: each frame's foreground mask, and the ground
    line (`object_scale.HeightByRow`: height against the row of the feet, from the boxes of the
    confirmed tracks observed so far) and a person's usual aspect as learned by that frame, None
    before the first fit. A moving camera's window takes its part of these: the suite's
    detector keeps its background in scene coordinates, so under a pan it sees what a fixed
    camera would."""
    stage = PipelineSettings.from_graph(load_graph("surveillance")).motion
    detector = DETECTORS.get(stage.detector_method).build(stage.detector_values)
    tracker = TRACKERS.get(stage.tracker_method).build(stage.tracker_values, 1)
    ground = HeightByRow(0.0)
    masks: list[np.ndarray] = []
    lines: list[tuple[float, float] | None] = []
    aspects: list[float | None] = []
    stamps = scene.stamps_ns()
    for stamp, frame in zip(stamps, scene.frames, strict=True):
        detection = detector.process(CameraFrame(stamp, frame))
        mask = detection.mask
        masks.append(np.zeros(frame.shape[:2], np.uint8) if mask is None else mask)
        found = detections_of(detection)
        t = (stamp - stamps[0]) / NS_PER_S
        tracks = tracker.step(Observation(t, found, detection.target_present))
        ground.observe(tracks.bboxes[tracks.status == TrackStatus.CONFIRMED])
        lines.append(ground.line)
        aspects.append(ground.aspect)
    return masks, GroundLines(lines, aspects=aspects)


def run_person(
    label: str,
    person: int,
    variant: str,
    setup: Variant | ParticleVariant,
    footage: Footage,
    region: Rect,
    scored: dict[int, Rect],
    start: int,
    run: int,
) -> PersonRun:
    refused = ""
    try:
        boxes = setup.run(footage, start, region, max(scored), seed=person + 1000 * run)
    except ValueError as error:  # the selection is refused: nothing is tracked
        boxes, refused = {}, str(error)
    scores = score_single_target(scored, boxes)
    iou = {k: (b.iou(boxes[k]) if boxes.get(k) else 0.0) for k, b in scored.items()}  # type: ignore[arg-type]
    kept = tuple(kept_through_gaps(scored, boxes))
    return PersonRun(label, person, variant, start, scores, iou, refused, run, kept)


def table(runs: list[PersonRun], variants: Sequence[str]) -> str:
    """One row per preset and variant: Q1, Q2 and success pooled over the people of a run, then
    averaged over runs, with their standard deviation over runs (sigma_Q, 0 for one run)."""
    header = (
        "| scenes | variant | people (refused) | frames | Q1 mean IoU | σ_Q1 | Q2 centre in box | "
        "σ_Q2 | IoU >= 0.5 | missed | Q1 at the true size | Q1 at the true centre | "
        "kept through occlusion |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    presets = sorted({preset_of(r) for r in runs})
    groups = list(presets)
    if any(p in MOVING_CAMERA for p in presets) and set(presets) - MOVING_CAMERA:
        groups.append(FIXED_CAMERA)
    groups += [
        name for name, prefix in PEOPLE_SETS.items() if any(p.startswith(prefix) for p in presets)
    ]
    for group in [*groups, "all"]:
        for variant in variants:
            chosen = [r for r in runs if r.variant == variant and in_group(r, group)]
            if chosen:
                lines.append(_row(group, variant, chosen))
    return "\n".join(lines)


#: issue 13's bar: an occlusion counts as kept when it is in at least this share of the runs
KEPT_SHARE = 0.9


def occlusions_kept(runs: list[PersonRun], variants: Sequence[str]) -> str:
    """Per variant, how many occlusions (scene, person, occlusion) are kept in at least
    KEPT_SHARE of the runs, and which are not with their runs kept: the per-occlusion reading of
    the table's kept column ("through a 1 s occlusion in at least 9 of 10 runs")."""
    lines = []
    for variant in variants:
        by_occlusion: dict[tuple[str, int, int], list[bool]] = {}
        for r in runs:
            if r.variant == variant:
                for k, kept in enumerate(r.kept):
                    by_occlusion.setdefault((r.scene, r.person, k), []).append(kept)
        if not by_occlusion:
            continue
        short = {o: v for o, v in sorted(by_occlusion.items()) if sum(v) < KEPT_SHARE * len(v)}
        listed = "; ".join(
            f"{scene} person {person} occlusion {k + 1}: {sum(v)}/{len(v)}"
            for (scene, person, k), v in short.items()
        )
        lines.append(
            f"{variant}: {len(by_occlusion) - len(short)} of {len(by_occlusion)} occlusions kept "
            f"in at least {KEPT_SHARE:.0%} of the runs" + (f"; not: {listed}" if listed else "")
        )
    return "\n".join(lines)


def in_group(run: PersonRun, group: str) -> bool:
    preset = preset_of(run)
    if group == FIXED_CAMERA:
        return preset not in MOVING_CAMERA
    if group in PEOPLE_SETS:
        return preset.startswith(PEOPLE_SETS[group])
    return group in ("all", preset)


def preset_of(run: PersonRun) -> str:
    return run.scene.rsplit("-", 1)[0]


def _row(preset: str, variant: str, chosen: list[PersonRun]) -> str:
    by_run = [
        pooled([r.scores for r in chosen if r.run == k]) for k in sorted({r.run for r in chosen})
    ]
    q1 = np.array([t.mean_iou for t in by_run])
    q2 = np.array([t.centre_in_box for t in by_run])
    spread = (lambda v: float(v.std(ddof=1))) if len(by_run) > 1 else (lambda v: 0.0)
    first = [r for r in chosen if r.run == 0]
    frames = by_run[0].frames
    missed = np.mean([t.missed / t.frames for t in by_run]) if frames else math.nan
    true_size = np.mean([t.iou_true_size for t in by_run])
    true_centre = np.mean([t.iou_true_centre for t in by_run])
    kept = [k for r in chosen for k in r.kept]
    label = f"{preset} (moving camera)" if preset in MOVING_CAMERA else preset
    return (
        f"| {label} | {variant} | {len(first)} ({sum(1 for r in first if r.refused)}) | "
        f"{frames} | {q1.mean():.3f} | {spread(q1):.3f} | {100 * q2.mean():.1f} % | "
        f"{100 * spread(q2):.1f} % | {100 * np.mean([t.success for t in by_run]):.1f} % | "
        f"{100 * missed:.1f} % | {true_size:.3f} | {true_centre:.3f} | "
        + (f"{sum(kept)}/{len(kept)} |" if kept else "– |")
    )


def plot_scene(label: str, runs: list[PersonRun], variants: Sequence[str], path: Path) -> None:
    """IoU over time, one panel per variant, one line per person (the first run)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, grid = plt.subplots(
        len(variants), 1, figsize=(10, 2.4 * len(variants)), sharex=True, squeeze=False
    )
    axes = grid[:, 0]
    for ax, variant in zip(axes, variants, strict=True):
        for r in runs:
            if r.variant == variant and r.run == 0 and r.iou:
                frames = range(min(r.iou), max(r.iou) + 1)  # a gap where the person is hidden
                iou = [r.iou.get(k, math.nan) for k in frames]
                ax.plot(frames, iou, lw=1, label=f"person {r.person}")
        ax.axhline(0.5, color="grey", lw=0.8, ls="--")
        ax.set_ylim(0, 1)
        ax.set_ylabel("IoU")
        ax.set_title(f"{label}: {variant}", fontsize=9)
    axes[-1].set_xlabel("frame")
    axes[0].legend(fontsize=7, ncol=6, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="single_target_benchmark",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", type=Path, default=Path("out/single_target"))
    parser.add_argument(
        "--cache", type=Path, default=Path("out/benchmark/scenes"), help="rendered scenes"
    )
    parser.add_argument(
        "--scenes",
        nargs="+",
        choices=sorted(PRESETS),
        help="presets (default: the scenes of real people, development and held-out)",
    )
    parser.add_argument("--seeds", type=int, default=2, help="scenes per preset")
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help="skip this many scenes of each preset (--first-seed 3 --seeds 3: three scenes "
        "that the rows of record, the first three, do not include)",
    )
    parser.add_argument("--frames", type=int, help="shorten every scene to this many frames")
    parser.add_argument("--background", choices=("vtest", "generated"), default="vtest")
    parser.add_argument("--runs", type=int, default=1, help="seeds per particle filter and person")
    parser.add_argument(
        "--sweep", action="store_true", help="particle counts and bins of the best filter"
    )
    parser.add_argument(
        "--variants", nargs="+", metavar="NAME", help="only these rows (names as in the table)"
    )
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs must be >= 1")
    if args.first_seed < 0:
        parser.error("--first-seed must be >= 0")
    variants: Mapping[str, Variant | ParticleVariant] = SWEEP if args.sweep else VARIANTS
    if args.variants:
        unknown = sorted(set(args.variants) - set(variants))
        if unknown:
            parser.error(f"unknown variants {unknown}; known: {sorted(variants)}")
        variants = {name: variants[name] for name in args.variants}
    args.out.mkdir(parents=True, exist_ok=True)
    background, described = background_image(args.background)
    runs: list[PersonRun] = []
    cutouts = RealPeople()
    for name in args.scenes or list(street.REAL_PEOPLE_PRESETS):
        for k in range(args.first_seed, args.first_seed + args.seeds):
            preset = PRESETS[name]
            config = replace(
                preset, seed=preset.seed + k, num_frames=args.frames or preset.num_frames
            )
            label = f"{name}-{config.seed}"
            scene = load_scene(prepare_scene(name, config, background, args.cache, cutouts))
            print(f"{label}: {len(people(scene))} people ...", flush=True)
            moving = name in MOVING_CAMERA
            scene_runs = run_scene(label, scene, variants, args.runs, moving)
            plot_scene(label, scene_runs, list(variants), args.out / f"iou-{label}.png")
            runs += scene_runs
    text = table(runs, list(variants))
    kept = occlusions_kept(runs, list(variants))
    if kept:
        text += "\n\nOcclusions:\n" + kept
    note = (
        f"Scenes over: {described}; each tracker started on each person's true box where first "
        f"{START_VISIBILITY:.0%} visible; {args.out}/iou-*.png plot IoU over time."
    )
    (args.out / "table.md").write_text(text + "\n\n" + note + "\n")
    write_json(
        [asdict(replace(r, iou={})) | {"frames_scored": len(r.iou)} for r in runs],
        args.out / "results.json",
    )
    print(f"\n{text}\n\n{note}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
