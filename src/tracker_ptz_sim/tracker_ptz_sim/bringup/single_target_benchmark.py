"""single_target_benchmark: seed 001's CamShift and seed 003's particle filter on the benchmark's
street scenes, one person at a time.

    single_target_benchmark                       every preset x 3 seeds, every variant
    single_target_benchmark --scenes walkers --seeds 1

Protocol: for every person of a scene, each tracker is started on the person's true box in the first
frame where they are at least 90 % visible and 40 px tall (as a user would draw it) and runs to
the person's last frame on the fixed, whole-scene camera. Scored as seed 003 scores its trackers
(`evaluation.single_target`) over the frames where the person is in the ground truth and visible
enough to be scored: Q1 mean IoU, Q2 share of centres in the 0.8 x shorter-side square, success
share at IoU >= 0.5. Variants: CamShift with the thesis's plain hue histogram; CamShift with the
suite's background-weighted histogram (the default), alone (each search starts at the last window,
as in the thesis) and with its search window placed at the one-step prediction of seed 001's
nominal or robust (exact lambda) Kalman filter (the thesis's future work). Seed 003's colour
particle filter (750 particles, K = 16; its random generator seeded by the person's id) as the
rows of its thesis's algorithm table: baseline, Ext 1 sigmoid, Ext 3 HSV, Ext 5 region covariance,
final (Ext 1 + Ext 2); then the final algorithm with 8 x the thesis's noise, alone and with a
background-weighted reference.

Writes to --out (default out/single_target): table.md, results.json and per scene iou-<scene>.png
(IoU over time per person and variant).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from tracker_detect.camshift import CamShiftConfig
from tracker_filter.colour_histograms import ColourSpace
from tracker_filter.colour_particle import (
    RECOMMENDED_SIGMA,
    Appearance,
    CovarianceAppearance,
    HistogramAppearance,
    ParticleFilterConfig,
    WeightCorrection,
)
from tracker_filter.filters import FilterFactory
from tracker_filter.models import seed001_nominal_model
from tracker_filter.robust_kalman import LambdaRule, RobustKalmanConfig, seed001_uncertainty
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.bringup.benchmark import background_image, prepare_scene
from tracker_ptz_sim.evaluation.prediction_study import PRIOR_STD
from tracker_ptz_sim.evaluation.scoring import write_json
from tracker_ptz_sim.evaluation.single_target import (
    SingleTargetScores,
    follow,
    follow_particles,
    pooled,
    score_single_target,
)
from tracker_ptz_sim.simulation import street
from tracker_ptz_sim.simulation.scenes import Scene, load_scene

#: the thesis's plain hue histogram, without the suite's colour checks (the thesis has none:
#: with them most people's selections are refused, as their hues do not stand out)
THESIS = CamShiftConfig(background_weighting=False, min_similarity=0.0, min_contrast=0.0)


Boxes = dict[int, Rect | None]


@dataclass(frozen=True)
class Variant:
    """CamShift with a histogram configuration and the filter placing its search window."""

    camshift: CamShiftConfig
    rule: LambdaRule | None  # the filter placing the search window; None: the last window

    def run(self, scene: Scene, start: int, region: Rect, last: int, seed: int) -> Boxes:
        stamps = scene.stamps_ns()
        guide = predictor(self.rule, scene.fps)
        return follow(scene.frames, stamps, start, region, last, guide, self.camshift)


@dataclass(frozen=True)
class ParticleVariant:
    """Seed 003's particle filter with one appearance and configuration."""

    appearance: Callable[[], Appearance]
    config: ParticleFilterConfig

    def run(self, scene: Scene, start: int, region: Rect, last: int, seed: int) -> Boxes:
        return follow_particles(
            scene.frames, start, region, last, self.appearance(), self.config, seed
        )


BASELINE = ParticleFilterConfig(correction=WeightCorrection.NONE, adaptive_noise=False)
WIDE = ParticleFilterConfig(sigma=tuple(8 * s for s in RECOMMENDED_SIGMA))

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
}
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


def run_scene(label: str, scene: Scene) -> list[PersonRun]:
    runs = []
    for person, truth in sorted(people(scene).items()):
        start = start_frame(scene, person)
        if start is None:
            continue
        scored = {k: box for k, box in truth.items() if k > start}
        if not scored:
            continue
        region = truth[start]
        for variant, setup in VARIANTS.items():
            refused = ""
            try:
                boxes = setup.run(scene, start, region, max(scored), seed=person)
            except ValueError as error:  # the selection is refused: nothing is tracked
                boxes, refused = {}, str(error)
            scores = score_single_target(scored, boxes)
            iou = {k: (b.iou(boxes[k]) if boxes.get(k) else 0.0) for k, b in scored.items()}  # type: ignore[arg-type]
            runs.append(PersonRun(label, person, variant, start, scores, iou, refused))
    return runs


def table(runs: list[PersonRun]) -> str:
    header = (
        "| scenes | variant | people (refused) | frames | Q1 mean IoU | Q2 centre in box | "
        "IoU >= 0.5 | missed |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    presets = sorted({r.scene.rsplit("-", 1)[0] for r in runs})
    for preset in [*presets, "all"]:
        for variant in VARIANTS:
            chosen = [
                r
                for r in runs
                if r.variant == variant and (preset == "all" or r.scene.startswith(preset + "-"))
            ]
            if not chosen:
                continue
            total = pooled([r.scores for r in chosen])
            missed = total.missed / total.frames if total.frames else math.nan
            refused = sum(1 for r in chosen if r.refused)
            lines.append(
                f"| {preset} | {variant} | {len(chosen)} ({refused}) | {total.frames} | "
                f"{total.mean_iou:.3f} | {100 * total.centre_in_box:.1f} % | "
                f"{100 * total.success:.1f} % | {100 * missed:.1f} % |"
            )
    return "\n".join(lines)


def plot_scene(label: str, runs: list[PersonRun], path: Path) -> None:
    """IoU over time, one panel per variant, one line per person."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(VARIANTS), 1, figsize=(10, 2.4 * len(VARIANTS)), sharex=True)
    for ax, variant in zip(axes, VARIANTS, strict=True):
        for r in runs:
            if r.variant == variant:
                frames = sorted(r.iou)
                ax.plot(frames, [r.iou[k] for k in frames], lw=1, label=f"person {r.person}")
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
    parser.add_argument("--scenes", nargs="+", choices=sorted(street.STREET_PRESETS))
    parser.add_argument("--seeds", type=int, default=3, help="scenes per preset")
    parser.add_argument("--frames", type=int, help="shorten every scene to this many frames")
    parser.add_argument("--background", choices=("vtest", "generated"), default="vtest")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    background, described = background_image(args.background)
    runs: list[PersonRun] = []
    for name in args.scenes or list(street.STREET_PRESETS):
        for k in range(args.seeds):
            preset = street.STREET_PRESETS[name]
            config = replace(
                preset, seed=preset.seed + k, num_frames=args.frames or preset.num_frames
            )
            label = f"{name}-{config.seed}"
            scene = load_scene(prepare_scene(name, config, background, args.cache))
            print(f"{label}: {len(people(scene))} people ...", flush=True)
            scene_runs = run_scene(label, scene)
            plot_scene(label, scene_runs, args.out / f"iou-{label}.png")
            runs += scene_runs
    text = table(runs)
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
