"""benchmark: the suite's accuracy of record, on realistic scenes with ground truth.

    benchmark                      every scene x configuration, in process; prints one table
    benchmark --graph              also through the real node graph (lockstep replay)
    benchmark --scenes walkers --configs suite --frames 150

Scenes are street scenes (`simulation.street`): people walking with a gait and perspective over a
real background (the median of the sample clip vtest.avi when it can be fetched, else a generated
plaza), with groups, crossings, people who stop, fluttering tape, foliage, flicker, lighting drift,
noise and JPEG compression. Ground truth is every person's visible box. Each configuration is a
graph with `node.param` overrides on its parameter files: `suite` is the surveillance graph as
shipped; `seed000` is seed 000's own mode (SSIM of frame k against k-3, the seed's tracker preset,
the camera jumping straight to the target); `colour` is the colour graph (seed 001: motion hands its
target over to CamShift, which the camera follows; one track, so its MOT scores count one person);
`particles` is the surveillance graph with seed 003's `colour_particles` tracker.

Scores (`evaluation.scoring`): CLEAR MOT, IDF1 and HOTA at IoU >= 0.5 in the camera view and over
the whole scene, and the pan-tilt figures. Writes to --out (default out/benchmark): results.json,
table.md, and per run tracks.txt, evaluation.json and plots.png (centring error, pan/tilt, followed
ids over time).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from tracker_filter.config import PRESETS
from tracker_ptz_sim.bringup import pipeline
from tracker_ptz_sim.bringup.graph import load_graph
from tracker_ptz_sim.evaluation import scoring
from tracker_ptz_sim.simulation import street
from tracker_ptz_sim.simulation.scenes import (
    META_NAME,
    Scene,
    label_reader,
    load_scene,
    write_scene,
)

#: Tracker parameters config/surveillance.yaml sets (a configuration on a preset resets them).
_SUITE_TRACKER = (
    "lead_time",
    "confirm_travel",
    "confirm_straightness",
    "selection_policy",
    "split_merged",
    "target_max_misses",
)


@dataclass(frozen=True)
class Configuration:
    """A graph (`graph.GRAPHS`) and node -> parameter -> value overrides on its params files."""

    graph: str = "surveillance"
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)


#: Configurations compared. A new tracker or detector joins the benchmark with one line here.
CONFIGURATIONS: dict[str, Configuration] = {
    "suite": Configuration(),
    "seed000": Configuration(
        overrides={
            "ssim_detector": {"method": "ssim"},
            # the seed's tracker preset, also for what surveillance.yaml sets on top of presets
            "tracker": {"preset": "seed000"}
            | {name: PRESETS["seed000"][name] for name in _SUITE_TRACKER},
            "ptz_controller": {"mode": "direct", "zoom_control": False},
            "ptz_camera": {"min_zoom": 1.0},
        }
    ),
    # seed 001: motion hands its target over to CamShift, which the camera follows (one track)
    "colour": Configuration("colour"),
    # seed 003: the surveillance graph with one colour particle filter per target as its tracker
    "particles": Configuration(overrides={"tracker": {"method": "colour_particles"}}),
}
PATHS = ("in-process", "graph")


@dataclass(frozen=True)
class RunScores:
    scene: str
    configuration: str
    path: str
    frames: int
    seconds: float  # wall time of the run (rendering the scene excluded)
    scores: dict[str, Any]
    seed: int = 0  # the scene's seed


def background_image(kind: str) -> tuple[np.ndarray | None, str]:
    """The scenes' background: the sample clip's median (`vtest`) or None (generated), and what
    it is in words."""
    if kind == "vtest":
        from tracker_ptz_sim.bringup.sample import SampleUnavailableError, fetch_sample

        try:
            return street.median_background(fetch_sample()), "median of vtest.avi"
        except (SampleUnavailableError, OSError) as error:
            print(f"vtest.avi is not available ({error}): generated backgrounds", file=sys.stderr)
    return None, "generated plaza"


def prepare_scene(
    name: str, config: street.StreetConfig, background: np.ndarray | None, cache: Path
) -> Path:
    """The scene directory for `config` over `background`, rendered once and cached by content
    (the generator's source included: a changed generator renders its scenes anew)."""
    key = hashlib.sha256(
        json.dumps(asdict(config), sort_keys=True).encode()
        + (background.tobytes() if background is not None else b"generated")
        + Path(street.__file__).read_bytes()
    ).hexdigest()[:12]
    root = cache / f"{name}-{key}"
    if not (root / META_NAME).exists():
        print(f"rendering scene {name} ({config.num_frames} frames) ...", flush=True)
        write_scene(street.generate_street(config, background), root)
    return root


def run_in_process(scene: Scene, settings: pipeline.PipelineSettings) -> scoring.RunTrace:
    steps = pipeline.run(scene.frames, scene.stamps_ns(), settings)
    return scoring.trace_from_steps(steps, scene.fps)


def run_graph(
    scene_dir: Path, graph_name: str, overrides: dict[str, dict[str, Any]], out: Path
) -> scoring.RunTrace:
    from tracker_ptz_sim.bringup import demo
    from tracker_ptz_sim.evaluation import run_report
    from tracker_ptz_sim.simulation.scenes import scene_video

    result = demo.run_graph(
        load_graph(graph_name), scene_video(scene_dir), out, overrides, demo.install_space(), 1800.0
    )
    if not result.complete:
        raise RuntimeError(f"the graph run is incomplete: {'; '.join(result.problems)}")
    return scoring.trace_from_frames(run_report.collect(result.bag))


def benchmark_one(
    scene_name: str,
    scene_dir: Path,
    scene: Scene,
    configuration: str,
    graph_name: str,
    overrides: dict[str, dict[str, Any]],
    path: str,
    out: Path,
) -> RunScores:
    run_dir = out / "runs" / f"{scene_name}-{configuration}-{path}"
    run_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    if path == "graph":
        trace = run_graph(scene_dir, graph_name, overrides, run_dir)
    else:
        settings = pipeline.PipelineSettings.from_graph(load_graph(graph_name), overrides)
        trace = run_in_process(scene, settings)
    seconds = time.perf_counter() - started
    title = f"{scene_name}, {configuration}, {path}"
    gt = scene_dir / "gt" / "gt.txt"
    scores = scoring.write_evaluation(trace, gt, run_dir, title, label_reader(scene_dir))
    return RunScores(scene_name, configuration, path, scores["frames"], seconds, scores)


def _merged(
    base: dict[str, dict[str, Any]], extra: dict[str, dict[str, Any]]
) -> dict[str, dict[str, Any]]:
    return {node: {**base.get(node, {}), **extra.get(node, {})} for node in {*base, *extra}}


def table(results: list[RunScores]) -> str:
    """The results as one Markdown table: per scene preset, configuration and path, the mean over
    the preset's seeds (object changes summed)."""
    header = (
        "| scene | configuration | path | runs | view MOTA | view IDF1 | view HOTA | scene MOTA | "
        "scene IDF1 | scene HOTA | target on object | object changes (unexplained) | "
        "centring error | frames/s |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    groups: dict[tuple[str, str, str], list[RunScores]] = {}
    for r in results:
        groups.setdefault((r.scene, r.configuration, r.path), []).append(r)
    for (scene, configuration, path), runs in groups.items():

        def mean(part: str, name: str, runs: list[RunScores] = runs) -> float:
            values = [r.scores[part][name] for r in runs]
            finite = [v for v in values if v is not None and v == v]
            return float(np.mean(finite)) if finite else math.nan

        changes = sum(r.scores["pan_tilt"]["followed_changes"] for r in runs)
        unexplained = sum(r.scores["pan_tilt"]["unexplained_changes"] for r in runs)
        error = mean("pan_tilt", "mean_center_error_px")
        speed = sum(r.frames for r in runs) / sum(r.seconds for r in runs)
        lines.append(
            f"| {scene} | {configuration} | {path} | {len(runs)} | {mean('in_view', 'mota'):.3f} | "
            f"{mean('in_view', 'idf1'):.3f} | {mean('in_view', 'hota'):.3f} | "
            f"{mean('whole_scene', 'mota'):.3f} | {mean('whole_scene', 'idf1'):.3f} | "
            f"{mean('whole_scene', 'hota'):.3f} | "
            f"{100 * mean('pan_tilt', 'on_object_share'):.1f} % | {changes} ({unexplained}) | "
            + ("n/a" if math.isnan(error) else f"{error:.0f} px")
            + f" | {speed:.1f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="benchmark", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=Path, default=Path("out/benchmark"))
    parser.add_argument("--scenes", nargs="+", choices=sorted(street.STREET_PRESETS))
    parser.add_argument("--configs", nargs="+", choices=sorted(CONFIGURATIONS))
    parser.add_argument("--graph", action="store_true", help="also run through the node graph")
    parser.add_argument("--frames", type=int, help="shorten every scene to this many frames")
    parser.add_argument(
        "--seeds", type=int, default=3, help="scenes per preset (its seed, seed + 1, ...)"
    )
    parser.add_argument(
        "--background", choices=("vtest", "generated"), default="vtest", help="scene background"
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NODE.PARAM=VALUE",
        help="override a parameter in every configuration",
    )
    args = parser.parse_args(argv)
    from tracker_ptz_sim.bringup.demo import parse_overrides

    extra = parse_overrides(args.set)
    scene_names = args.scenes or list(street.STREET_PRESETS)
    configurations = args.configs or list(CONFIGURATIONS)
    paths = PATHS if args.graph else PATHS[:1]
    args.out.mkdir(parents=True, exist_ok=True)
    background, described = background_image(args.background)
    results: list[RunScores] = []
    failures: list[str] = []
    for name in scene_names:
        for k in range(args.seeds):
            preset = street.STREET_PRESETS[name]
            config = replace(
                preset, seed=preset.seed + k, num_frames=args.frames or preset.num_frames
            )
            scene_dir = prepare_scene(name, config, background, args.out / "scenes")
            scene = load_scene(scene_dir)
            for configuration in configurations:
                for path in paths:
                    label = f"{name}-{config.seed}"
                    print(f"{label} / {configuration} / {path} ...", flush=True)
                    chosen = CONFIGURATIONS[configuration]
                    overrides = _merged(chosen.overrides, extra)
                    try:
                        result = benchmark_one(
                            label,
                            scene_dir,
                            scene,
                            configuration,
                            chosen.graph,
                            overrides,
                            path,
                            args.out,
                        )
                    except RuntimeError as error:  # an incomplete graph run: say so, go on
                        failures.append(f"{label} / {configuration} / {path}: {error}")
                        print(f"FAILED: {failures[-1]}", file=sys.stderr, flush=True)
                        continue
                    results.append(replace(result, scene=name, seed=config.seed))
                    print(scoring.format_scores(result.scores), flush=True)
    text = table(results)
    note = f"Scenes over: {described}; {args.out}/runs/* hold each run's tracks, scores and plots."
    if failures:
        note += "\n\nRuns that did not complete (left out of the table):\n" + "\n".join(failures)
    (args.out / "table.md").write_text(text + "\n\n" + note + "\n")
    scoring.write_json([asdict(r) for r in results], args.out / "results.json")
    print(f"\n{text}\n\n{note}")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
