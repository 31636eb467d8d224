"""benchmark: the suite's accuracy of record, on realistic scenes with ground truth.

    benchmark                      every scene x configuration, in process; prints one table
    benchmark --graph              also through the real node graph (lockstep replay)
    benchmark --scenes walkers --configs suite --frames 150

Scenes are street scenes (`simulation.street`): people walking with a gait and perspective over a
real background (the median of the sample clip vtest.avi when it can be fetched, else a generated
plaza), with groups, crossings, fluttering tape, foliage, flicker, lighting drift, noise and JPEG
compression. Ground truth is every person's visible box. Each configuration is a set of
`node.param` overrides on config/surveillance.yaml; `seed000` is seed 000's own mode (SSIM of frame
k against k-3, the seed's tracker preset, the camera jumping straight to the target).

Scores (`evaluation.scoring`): CLEAR MOT, IDF1 and HOTA at IoU >= 0.5 in the camera view and over
the whole scene, and the pan-tilt figures. Writes to --out (default out/benchmark): results.json,
table.md, and per run tracks.txt, evaluation.json and plots.png (centring error, pan/tilt, followed
ids over time).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from tracker_ptz_sim.bringup import pipeline
from tracker_ptz_sim.evaluation import scoring
from tracker_ptz_sim.simulation import street
from tracker_ptz_sim.simulation.scenes import META_NAME, Scene, load_scene, write_scene

#: Configurations compared: name -> node -> parameter -> value, over config/surveillance.yaml.
#: A new tracker or detector joins the benchmark with one line here.
CONFIGURATIONS: dict[str, dict[str, dict[str, Any]]] = {
    "suite": {},
    "seed000": {
        "ssim_detector": {"method": "ssim"},
        "tracker": {"preset": "seed000", "confirm_travel": 0.0},
        "ptz_controller": {"mode": "direct"},
    },
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
    """The scene directory for `config` over `background`, rendered once and cached by content."""
    key = hashlib.sha256(
        json.dumps(asdict(config), sort_keys=True).encode()
        + (background.tobytes() if background is not None else b"generated")
    ).hexdigest()[:12]
    root = cache / f"{name}-{key}"
    if not (root / META_NAME).exists():
        print(f"rendering scene {name} ({config.num_frames} frames) ...", flush=True)
        write_scene(street.generate_street(config, background), root)
    return root


def run_in_process(scene: Scene, settings: pipeline.PipelineSettings) -> scoring.RunTrace:
    steps = pipeline.run(scene.frames, scene.stamps_ns(), settings)
    return scoring.trace_from_steps(steps, scene.fps)


def run_graph(scene_dir: Path, overrides: dict[str, dict[str, Any]], out: Path) -> scoring.RunTrace:
    from tracker_ptz_sim.bringup import demo
    from tracker_ptz_sim.bringup.graph import load_graph
    from tracker_ptz_sim.evaluation import run_report
    from tracker_ptz_sim.simulation.scenes import scene_video

    result = demo.run_graph(
        load_graph(), scene_video(scene_dir), out, overrides, demo.install_space(), 1800.0
    )
    if not result.complete:
        raise RuntimeError(f"the graph run is incomplete: {'; '.join(result.problems)}")
    return scoring.trace_from_frames(run_report.collect(result.bag))


def benchmark_one(
    scene_name: str,
    scene_dir: Path,
    scene: Scene,
    configuration: str,
    path: str,
    out: Path,
) -> RunScores:
    overrides = CONFIGURATIONS[configuration]
    run_dir = out / "runs" / f"{scene_name}-{configuration}-{path}"
    run_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    if path == "graph":
        trace = run_graph(scene_dir, overrides, run_dir)
    else:
        from tracker_ptz_sim.bringup.graph import load_graph

        settings = pipeline.PipelineSettings.from_params_file(load_graph().params_file, overrides)
        trace = run_in_process(scene, settings)
    seconds = time.perf_counter() - started
    title = f"{scene_name}, {configuration}, {path}"
    scores = scoring.write_evaluation(trace, scene_dir / "gt" / "gt.txt", run_dir, title)
    return RunScores(scene_name, configuration, path, scores["frames"], seconds, scores)


def table(results: list[RunScores]) -> str:
    """The results as one Markdown table."""
    header = (
        "| scene | configuration | path | view MOTA | view IDF1 | view HOTA | scene MOTA | "
        "scene IDF1 | scene HOTA | target on object | object changes (unexplained) | "
        "centring error | frames/s |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for r in results:
        v, s, p = r.scores["in_view"], r.scores["whole_scene"], r.scores["pan_tilt"]
        error = p["mean_center_error_px"]
        lines.append(
            f"| {r.scene} | {r.configuration} | {r.path} | {v['mota']:.3f} | {v['idf1']:.3f} | "
            f"{v['hota']:.3f} | {s['mota']:.3f} | {s['idf1']:.3f} | {s['hota']:.3f} | "
            f"{100 * p['on_object_share']:.1f} % | {p['followed_changes']} "
            f"({p['unexplained_changes']}) | "
            + ("n/a" if error is None or error != error else f"{error:.0f} px")
            + f" | {r.frames / r.seconds:.1f} |"
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
        "--background", choices=("vtest", "generated"), default="vtest", help="scene background"
    )
    args = parser.parse_args(argv)
    scene_names = args.scenes or list(street.STREET_PRESETS)
    configurations = args.configs or list(CONFIGURATIONS)
    paths = PATHS if args.graph else PATHS[:1]
    args.out.mkdir(parents=True, exist_ok=True)
    background, described = background_image(args.background)
    results: list[RunScores] = []
    for name in scene_names:
        config = street.STREET_PRESETS[name]
        if args.frames:
            config = replace(config, num_frames=args.frames)
        scene_dir = prepare_scene(name, config, background, args.out / "scenes")
        scene = load_scene(scene_dir)
        for configuration in configurations:
            for path in paths:
                print(f"{name} / {configuration} / {path} ...", flush=True)
                result = benchmark_one(name, scene_dir, scene, configuration, path, args.out)
                print(scoring.format_scores(result.scores), flush=True)
                results.append(result)
    text = table(results)
    note = f"Scenes over: {described}; {args.out}/runs/* hold each run's tracks, scores and plots."
    (args.out / "table.md").write_text(text + "\n\n" + note + "\n")
    scoring.write_json([asdict(r) for r in results], args.out / "results.json")
    print(f"\n{text}\n\n{note}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
