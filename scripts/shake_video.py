"""Shake a video as a camera on a mast in the wind would: every frame shifted by a random whole
number of px per axis, drawn uniformly from [-pixels, pixels] (seeded), edges replicated.

    python scripts/shake_video.py IN.avi OUT.avi --pixels 3 --seed 0
    run_demo --video OUT.avi

The pose the replay reports stays where it was: the shake is what the detector has to take out
(`ssim_detector.register_reach`, the README's "A camera shaken off its pose").
"""

from __future__ import annotations

import argparse
import sys

import cv2
import numpy as np


def shake(source: str, target: str, pixels: int, seed: int) -> int:
    """Write `target` (MJPG) with the frames of `source` shaken; the number of frames written."""
    capture = cv2.VideoCapture(source)
    if not capture.isOpened():
        raise SystemExit(f"cannot open {source}")
    fps = capture.get(cv2.CAP_PROP_FPS) or 10.0
    size = (int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    writer = cv2.VideoWriter(target, cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    rng = np.random.default_rng(seed)
    count = 0
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        dx, dy = rng.integers(-pixels, pixels + 1, 2)
        shift = np.float32([[1, 0, dx], [0, 1, dy]])
        writer.write(cv2.warpAffine(frame, shift, size, borderMode=cv2.BORDER_REPLICATE))
        count += 1
    writer.release()
    return count


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("--pixels", type=int, default=3, help="largest shift per axis [px]")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    count = shake(args.source, args.target, args.pixels, args.seed)
    print(f"wrote {args.target}: {count} frames shaken by up to {args.pixels} px")
    return 0 if count else 1


if __name__ == "__main__":
    sys.exit(main())
