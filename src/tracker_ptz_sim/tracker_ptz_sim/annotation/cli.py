"""annotate: ground truth for a real clip, made with an assistant and reviewed by eye.

    annotate assist VIDEO DIR     the assistant's fused person boxes per frame -> DIR/detections.txt
                                  (slow: ~3 s a frame on 2 cores), and DIR/seqinfo.ini
    annotate link DIR             detections -> tracks with ids -> DIR/assistant.txt
    annotate apply DIR            assistant.txt + DIR/corrections.yaml -> DIR/gt/gt.txt
    annotate sheet VIDEO DIR      contact sheets of every 10th frame with boxes and ids -> DIR/review/
    annotate strip VIDEO DIR --frames 20-75:5 --zoom X,Y,W,H [--scale 3]
                                  those frames of that region magnified, with a coordinate
                                  grid to read boxes off -> DIR/review/strip.png
    annotate all VIDEO DIR        assist, link, apply, sheet

The ground truth is reproducible from the clip and corrections.yaml: `assist`, `link` and `apply`
are deterministic. Files are MOTChallenge text (frame numbers from 1). See `annotation.linking`
for how detections become tracks and `annotation.corrections` for the corrections file.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tracker_ptz_sim.annotation import corrections, linking, review
from tracker_ptz_sim.annotation.assistant import Assistant
from tracker_ptz_sim.simulation import ground_truth
from tracker_ptz_sim.simulation.frame_sources import video_frames

DETECTIONS = "detections.txt"
ASSISTANT = "assistant.txt"
CORRECTIONS = "corrections.yaml"
GT = "gt/gt.txt"


def assist(video: Path, folder: Path) -> int:
    """The fused boxes of every frame -> DIR/detections.txt, and DIR/seqinfo.ini."""
    folder.mkdir(parents=True, exist_ok=True)
    assistant = Assistant()
    lines, size = [], (0, 0)
    for index, frame in enumerate(video_frames(video)):
        size = (frame.shape[1], frame.shape[0])
        for x0, y0, x1, y1, score in assistant.detect(frame, linking.DETECTION_FLOOR):
            lines.append(
                f"{index + 1},-1,{x0:.2f},{y0:.2f},{x1 - x0:.2f},{y1 - y0:.2f},{score:.4f},-1,-1,-1"
            )
        if (index + 1) % 20 == 0:
            print(f"assist: frame {index + 1}", flush=True)
    (folder / DETECTIONS).write_text("\n".join(lines) + "\n")
    ground_truth.write_seqinfo(folder, video, size, index + 1)
    print(f"assist: {index + 1} frames, {len(lines)} boxes -> {folder / DETECTIONS}")
    return 0


def link(folder: Path) -> int:
    detections = ground_truth.read_detections(folder / DETECTIONS)
    tracks = linking.link(detections)
    ground_truth.write_tracks(tracks, folder / ASSISTANT)
    print(f"link: {len(tracks.ids())} tracks, {len(tracks)} boxes -> {folder / ASSISTANT}")
    return 0


def reviewed(folder: Path) -> tuple[ground_truth.Tracks, corrections.Applied]:
    """The ground truth: the assistant's tracks, corrected, finished (interpolated boxes have
    score 0); and what the corrections did."""
    tracks = ground_truth.read_tracks(folder / ASSISTANT)
    fixes = corrections.load(folder / CORRECTIONS) if (folder / CORRECTIONS).exists() else []
    result = corrections.apply(tracks, fixes, ground_truth.read_detections(folder / DETECTIONS))
    info = ground_truth.read_seqinfo(folder)
    return linking.finish(result.tracks, info.width, info.height), result


def apply(folder: Path) -> int:
    gt, result = reviewed(folder)
    (folder / GT).parent.mkdir(parents=True, exist_ok=True)
    ground_truth.write_ground_truth(gt, folder / GT)
    print(f"apply: {result.summary()}; {len(gt.ids())} people, {len(gt)} boxes -> {folder / GT}")
    return 0


def sheet(video: Path, folder: Path, every: int, region: tuple[int, int, int, int] | None) -> int:
    tracks, _ = reviewed(folder)
    pages = review.contact_sheets(video, tracks, folder / "review", every)
    if region is not None:
        pages += review.contact_sheets(video, tracks, folder / "review", every, region)
    print(f"sheet: {len(pages)} pages of every {every}th frame -> {folder / 'review'}")
    return 0


def frame_range(text: str) -> range:
    """ "20-75:5" -> range(20, 76, 5); "20-75" -> every frame."""
    span, _, step = text.partition(":")
    first, _, last = span.partition("-")
    return range(int(first), int(last or first) + 1, int(step or 1))


def show_strip(
    video: Path, folder: Path, frames: range, region: tuple[int, int, int, int], scale: int
) -> int:
    path = folder / "review" / "strip.png"
    count = review.strip(video, reviewed(folder)[0], frames, region, scale, path)
    print(f"strip: {count} frames -> {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="annotate", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("step", choices=("assist", "link", "apply", "sheet", "strip", "all"))
    parser.add_argument("paths", nargs="+", type=Path, help="VIDEO DIR (assist, sheet, all) or DIR")
    parser.add_argument("--every", type=int, default=10, help="sheet: every n-th frame")
    parser.add_argument(
        "--zoom",
        type=lambda text: tuple(int(v) for v in text.split(",")),
        metavar="X,Y,W,H",
        help="sheet: also pages of this region magnified 2x (vtest.avi: 250,110,320,200)",
    )
    parser.add_argument("--frames", type=frame_range, help="strip: FIRST-LAST[:STEP]")
    parser.add_argument("--scale", type=int, default=3, help="strip: magnification")
    args = parser.parse_args(argv)
    needs_video = args.step in ("assist", "sheet", "strip", "all")
    if len(args.paths) != (2 if needs_video else 1):
        parser.error(f"{args.step} takes {'VIDEO DIR' if needs_video else 'DIR'}")
    folder = args.paths[-1]
    if args.step == "assist":
        return assist(args.paths[0], folder)
    if args.step == "link":
        return link(folder)
    if args.step == "apply":
        return apply(folder)
    if args.step == "sheet":
        return sheet(args.paths[0], folder, args.every, args.zoom)
    if args.step == "strip":
        if args.frames is None or args.zoom is None:
            parser.error("strip takes --frames and --zoom")
        return show_strip(args.paths[0], folder, args.frames, args.zoom, args.scale)
    return (
        assist(args.paths[0], folder)
        or link(folder)
        or apply(folder)
        or sheet(args.paths[0], folder, args.every, args.zoom)
    )


if __name__ == "__main__":
    sys.exit(main())
