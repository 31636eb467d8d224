"""evaluate: replay a scene with ground truth through the graph and score it.

    evaluate --scene DIR                  a synthetic scene written by make_scene (video + gt/gt.txt)
    evaluate --video FILE --gt gt.txt     any video with MOTChallenge ground truth
    evaluate --bag out/bag --gt gt.txt    score a run recorded before, without replaying

Reports the scores of `tracker_ptz_sim.evaluation.scoring` (CLEAR MOT, IDF1 and HOTA at IoU >= 0.5
in the camera view and in the whole scene, and the pan-tilt figures). Writes to --out:
summary.json (the run: frames, throughput, latencies, lock share), evaluation.json (the scores),
tracks.txt (observed tracks, MOTChallenge) and plots.png (centring error, pan/tilt, followed ids).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tracker_ptz_sim.bringup.graph import GRAPHS, load_graph
from tracker_ptz_sim.evaluation import run_files, run_report, scoring
from tracker_ptz_sim.simulation.scene_files import label_reader


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--scene", type=Path, help="scene directory from make_scene")
    source.add_argument("--video", type=Path, help="video (with --gt)")
    source.add_argument("--bag", type=Path, help="a recorded run's bag directory (with --gt)")
    parser.add_argument("--gt", type=Path, help="MOTChallenge gt.txt")
    parser.add_argument("--out", type=Path, default=Path("out/eval"))
    parser.add_argument("--mode", choices=("servo", "direct"), help="ptz_controller mode")
    parser.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    parser.add_argument("--timeout", type=float, default=1800.0)
    parser.add_argument(
        "--graph",
        choices=list(GRAPHS),
        default="surveillance",
        help="the graph run (and, with --bag, the one that recorded it: its track_labels)",
    )
    parser.add_argument(
        "--labels",
        help="comma-separated labels of the tracks scored (default: the tracker's track_labels "
        "in the graph with --set applied; 'any' = every track)",
    )
    args = parser.parse_args(argv)

    gt = args.gt or (args.scene / "gt" / "gt.txt" if args.scene else None)
    if gt is None or not gt.exists():
        parser.error(f"ground truth not found: {gt} (pass --gt)")
    args.out.mkdir(parents=True, exist_ok=True)
    from tracker_ptz_sim.bringup import demo
    from tracker_ptz_sim.bringup.graph import unknown_override_nodes
    from tracker_ptz_sim.bringup.pipeline import PipelineSettings

    overrides = demo.parse_overrides(args.set)
    graph = load_graph(args.graph)
    problem = unknown_override_nodes(overrides, [graph])
    if problem:
        parser.error(problem)
    labels = (
        tuple(args.labels.split(","))
        if args.labels
        else PipelineSettings.from_graph(graph, overrides).followed_labels
    )
    bag, run = args.bag, None
    if bag is None:
        from tracker_ptz_sim.simulation.scene_files import scene_video

        video = args.video or scene_video(args.scene)
        if args.mode:
            overrides.setdefault("ptz_controller", {})["mode"] = args.mode
        run = demo.run_graph(graph, video, args.out, overrides, demo.install_space(), args.timeout)
        bag = run.bag
        if not run.complete:
            print(f"the run is incomplete: {'; '.join(run.problems)} (see {args.out}/logs)")
            return 130 if run.interrupted_by else 1
    frames = run_report.collect(bag)
    summary = run_report.summarize(frames, run_report.message_counts(frames))
    run_report.write_summary(summary, args.out / "summary.json", run.as_dict() if run else None)
    object_labels = label_reader(
        gt.parent.parent
    )  # a scene directory: <scene>/gt/gt.txt, <scene>/masks
    result = run_files.write_evaluation(
        scoring.trace_from_frames(frames, labels), gt, args.out, label_of=object_labels
    )
    print(f"Evaluation against {gt}:\n{scoring.format_scores(result)}")
    print(f"Wrote {args.out}/: summary.json, evaluation.json, tracks.txt, plots.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
