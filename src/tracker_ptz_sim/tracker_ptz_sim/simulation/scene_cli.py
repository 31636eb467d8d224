"""make_scene: write a deterministic synthetic scene with ground truth.

    make_scene OUT_DIR [--width 640 --height 480 --num-frames 200 --num-objects 3 --seed 1 ...]

Every SceneConfig field is an option (ranges as two values: --speed-range 20 60). Writes the
lossless video, MOTChallenge gt/gt.txt, per-frame label masks, seqinfo.ini and scene.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import typing
from pathlib import Path

from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene, write_scene


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="make_scene", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("out_dir", type=Path, help="directory to write the scene into")
    hints = typing.get_type_hints(SceneConfig)
    for field in dataclasses.fields(SceneConfig):
        kind = hints[field.name]
        flag = "--" + field.name.replace("_", "-")
        if kind is bool:
            parser.add_argument(flag, action=argparse.BooleanOptionalAction, default=field.default)
        elif typing.get_origin(kind) is tuple:
            item = typing.get_args(kind)[0]
            parser.add_argument(
                flag, type=item, nargs=2, default=field.default, metavar=("MIN", "MAX")
            )
        else:
            parser.add_argument(flag, type=kind, default=field.default)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = vars(build_parser().parse_args(argv))
    out_dir = args.pop("out_dir")
    for name, value in args.items():
        if isinstance(value, list):
            args[name] = tuple(value)
    try:
        config = SceneConfig(**args)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    scene = generate_scene(config)
    paths = write_scene(scene, out_dir)
    print(f"wrote {scene.num_frames} frames ({config.width}x{config.height}) to {paths.root}:")
    print(f"  video {paths.video}\n  ground truth {paths.gt}\n  masks {paths.masks}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
