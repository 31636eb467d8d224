"""annotate: ground truth for a real clip, made with an assistant and reviewed by eye.

    annotate assist VIDEO DIR     the assistant's fused person boxes per frame -> DIR/detections.txt
                                  (slow: ~3 s a frame on 2 cores), and DIR/seqinfo.ini
    annotate link DIR             detections -> tracks with ids -> DIR/assistant.txt
    annotate apply DIR            assistant.txt + DIR/corrections.yaml -> DIR/gt/gt.txt
    annotate sheet VIDEO DIR      contact sheets of every 10th frame with boxes and ids -> DIR/review/
    annotate VIDEO DIR            all four

The ground truth is reproducible from the clip and corrections.yaml: `assist`, `link` and `apply`
are deterministic. Files are MOTChallenge text (frame numbers from 1). See `annotation.linking`
for how detections become tracks and `annotation.corrections` for the corrections file.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tracker_ptz_sim.annotation import corrections, linking, review
from tracker_ptz_sim.annotation.assistant import Assistant, read_frames

DETECTIONS = "detections.txt"
ASSISTANT = "assistant.txt"
CORRECTIONS = "corrections.yaml"
GT = "gt/gt.txt"


def assist(video: Path, folder: Path) -> int:
    """The fused boxes of every frame -> DIR/detections.txt, and DIR/seqinfo.ini."""
    folder.mkdir(parents=True, exist_ok=True)
    assistant = Assistant()
    lines, size = [], (0, 0)
    for index, frame in enumerate(read_frames(video)):
        size = (frame.shape[1], frame.shape[0])
        for x0, y0, x1, y1, score in assistant.detect(frame, linking.DETECTION_FLOOR):
            lines.append(
                f"{index + 1},-1,{x0:.2f},{y0:.2f},{x1 - x0:.2f},{y1 - y0:.2f},{score:.4f},-1,-1,-1"
            )
        if (index + 1) % 20 == 0:
            print(f"assist: frame {index + 1}", flush=True)
    (folder / DETECTIONS).write_text("\n".join(lines) + "\n")
    linking.write_seqinfo(folder, video, size, index + 1)
    print(f"assist: {index + 1} frames, {len(lines)} boxes -> {folder / DETECTIONS}")
    return 0


def link(folder: Path) -> int:
    detections = linking.read_detections(folder / DETECTIONS)
    tracks = linking.link(detections)
    linking.write_tracks(tracks, folder / ASSISTANT)
    print(f"link: {len(tracks.ids())} tracks, {len(tracks)} boxes -> {folder / ASSISTANT}")
    return 0


def apply(folder: Path) -> int:
    tracks = linking.read_tracks(folder / ASSISTANT)
    fixes = corrections.load(folder / CORRECTIONS) if (folder / CORRECTIONS).exists() else []
    result = corrections.apply(tracks, fixes)
    info = linking.read_seqinfo(folder)
    gt = linking.finish(result.tracks, info.width, info.height)
    (folder / GT).parent.mkdir(parents=True, exist_ok=True)
    linking.write_ground_truth(gt, folder / GT)
    print(f"apply: {result.summary()}; {len(gt.ids())} people, {len(gt)} boxes -> {folder / GT}")
    return 0


def sheet(video: Path, folder: Path, every: int) -> int:
    source = folder / GT if (folder / GT).exists() else folder / ASSISTANT
    pages = review.contact_sheets(video, linking.read_tracks(source), folder / "review", every)
    print(f"sheet: {len(pages)} pages of every {every}th frame of {source} -> {folder / 'review'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="annotate", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("step", choices=("assist", "link", "apply", "sheet", "all"))
    parser.add_argument("paths", nargs="+", type=Path, help="VIDEO DIR (assist, sheet, all) or DIR")
    parser.add_argument("--every", type=int, default=10, help="sheet: every n-th frame")
    args = parser.parse_args(argv)
    needs_video = args.step in ("assist", "sheet", "all")
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
        return sheet(args.paths[0], folder, args.every)
    return (
        assist(args.paths[0], folder)
        or link(folder)
        or apply(folder)
        or sheet(args.paths[0], folder, args.every)
    )


if __name__ == "__main__":
    sys.exit(main())
