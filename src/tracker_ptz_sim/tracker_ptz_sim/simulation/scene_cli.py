"""make_scene: write a deterministic synthetic scene with ground truth.

    make_scene OUT_DIR [--width 640 --height 480 --num-frames 200 --num-objects 3 --seed 1 ...]
    make_scene OUT_DIR --street walkers [--background IMAGE_OR_VIDEO --seed 3 --num-frames 100]

Every SceneConfig field is an option (ranges as two values: --speed-range 20 60). With --street
PRESET it writes a street scene instead (people walking over a real or procedural background, see
tracker_ptz_sim.simulation.street); then only --seed, --num-frames and --background apply
(--background: an image, or a video whose per-pixel median is the background). Writes the
lossless video, MOTChallenge gt/gt.txt, per-frame label masks, seqinfo.ini and scene.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import typing
from pathlib import Path

import cv2
import numpy as np

from tracker_ptz_sim.simulation.scenes import Scene, SceneConfig, generate_scene, write_scene
from tracker_ptz_sim.simulation.street import (
    STREET_PRESETS,
    generate_street,
    median_background,
)

STREET_OPTIONS = ("seed", "num_frames")  # the SceneConfig options that apply to a street preset


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="make_scene", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("out_dir", type=Path, help="directory to write the scene into")
    parser.add_argument(
        "--street", choices=sorted(STREET_PRESETS), help="write this street scene preset instead"
    )
    parser.add_argument(
        "--background", type=Path, help="with --street: background image, or video (its median)"
    )
    hints = typing.get_type_hints(SceneConfig)
    for field in dataclasses.fields(SceneConfig):
        # None = not given (so --street can tell which options were); main() fills in the default
        kind = hints[field.name]
        flag = "--" + field.name.replace("_", "-")
        note = f"default: {field.default}"
        if kind is bool:
            parser.add_argument(flag, action=argparse.BooleanOptionalAction, help=note)
        elif typing.get_origin(kind) is tuple:
            item = typing.get_args(kind)[0]
            parser.add_argument(flag, type=item, nargs=2, metavar=("MIN", "MAX"), help=note)
        else:
            parser.add_argument(flag, type=kind, help=note)
    return parser


def load_background(path: Path) -> np.ndarray:
    """An image file as it is, or the per-pixel median of a video."""
    image = cv2.imread(str(path), cv2.IMREAD_COLOR) if path.is_file() else None
    return image if image is not None else median_background(path)


def _street_scene(preset: str, args: dict[str, typing.Any], background: Path | None) -> Scene:
    given = {name: value for name, value in args.items() if value is not None}
    ignored = [name for name in given if name not in STREET_OPTIONS]
    if ignored:
        flags = ", ".join("--" + name.replace("_", "-") for name in ignored)
        raise ValueError(f"{flags} do not apply with --street (only --seed and --num-frames do)")
    config = dataclasses.replace(STREET_PRESETS[preset], **given)
    return generate_street(config, None if background is None else load_background(background))


def main(argv: list[str] | None = None) -> int:
    args = vars(build_parser().parse_args(argv))
    out_dir = args.pop("out_dir")
    street, background = args.pop("street"), args.pop("background")
    for name, value in args.items():
        if isinstance(value, list):
            args[name] = tuple(value)
    try:
        if street is not None:
            scene = _street_scene(street, args, background)
        elif background is not None:
            raise ValueError("--background needs --street")
        else:
            defaults: dict[str, typing.Any] = {
                f.name: f.default for f in dataclasses.fields(SceneConfig)
            }
            config = SceneConfig(**{n: defaults[n] if v is None else v for n, v in args.items()})
            scene = generate_scene(config)
    except (ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    paths = write_scene(scene, out_dir)
    height, width = scene.frames.shape[1:3]
    print(f"wrote {scene.num_frames} frames ({width}x{height}) to {paths.root}:")
    print(f"  video {paths.video}\n  ground truth {paths.gt}\n  masks {paths.masks}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
