"""make_scene: write a deterministic synthetic scene with ground truth.

    make_scene OUT_DIR [--width 640 --height 480 --num-frames 200 --num-objects 3 --seed 1 ...]
    make_scene OUT_DIR --street walkers [--background IMAGE_OR_VIDEO --seed 3 --num-frames 100]
    make_scene OUT_DIR --small-objects [--num-objects 40 --crossings 5 --seed 2 --background ...]

Every SceneConfig field is an option (ranges as two values: --speed-range 20 60). With --street
PRESET it writes a street scene instead (people walking over a real or procedural background, see
tracker_ptz_sim.simulation.street); then only --seed, --num-frames and --background apply
(--background: an image, or a video whose per-pixel median is the background). With
--small-objects it writes a small-object scene (many 10-30 px insects and birds with crossings and
static occluders over a real or generated ground, see tracker_ptz_sim.simulation.small_objects):
every SmallObjectsConfig field is an option (speeds in px/frame), and --background applies. Writes
the lossless video, MOTChallenge gt/gt.txt, per-frame label masks, seqinfo.ini and scene.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import typing
from pathlib import Path

import cv2
import numpy as np

from tracker_ptz_sim.simulation.scene_files import write_scene
from tracker_ptz_sim.simulation.scenes import Scene, SceneConfig, generate_scene
from tracker_ptz_sim.simulation.small_objects import SmallObjectsConfig, generate_small_objects
from tracker_ptz_sim.simulation.street import (
    STREET_PRESETS,
    generate_street,
    median_background,
)

STREET_OPTIONS = ("seed", "num_frames")  # the SceneConfig options that apply to a street preset
SCENE_FIELDS = {f.name: f for f in dataclasses.fields(SceneConfig)}
SMALL_FIELDS = {f.name: f for f in dataclasses.fields(SmallObjectsConfig)}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="make_scene", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("out_dir", type=Path, help="directory to write the scene into")
    kind_of_scene = parser.add_mutually_exclusive_group()
    kind_of_scene.add_argument(
        "--street", choices=sorted(STREET_PRESETS), help="write this street scene preset instead"
    )
    kind_of_scene.add_argument(
        "--small-objects",
        action="store_true",
        help="write a small-object scene instead (SmallObjectsConfig options)",
    )
    parser.add_argument(
        "--background",
        type=Path,
        help="with --street or --small-objects: background image, or video (its median)",
    )
    # a field of both configs parses as SceneConfig's (the old scenes' options stay as they were)
    hints = typing.get_type_hints(SmallObjectsConfig) | typing.get_type_hints(SceneConfig)
    for name in SCENE_FIELDS | SMALL_FIELDS:
        # None = not given (so --street can tell which options were); main() fills in the default
        kind = hints[name]
        flag = "--" + name.replace("_", "-")
        notes = [f"default: {SCENE_FIELDS[name].default}"] if name in SCENE_FIELDS else []
        if name in SMALL_FIELDS:
            notes.append(f"with --small-objects: {SMALL_FIELDS[name].default}")
        note = "; ".join(notes if name in SCENE_FIELDS else ["only " + notes[0]])
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


def _small_objects_scene(args: dict[str, typing.Any], background: Path | None) -> Scene:
    given = {name: value for name, value in args.items() if value is not None}
    ignored = [name for name in given if name not in SMALL_FIELDS]
    if ignored:
        raise ValueError(f"{_flags(ignored)} do not apply with --small-objects")
    config = SmallObjectsConfig(**given)
    return generate_small_objects(
        config, None if background is None else load_background(background)
    )


def _flags(names: list[str]) -> str:
    return ", ".join("--" + name.replace("_", "-") for name in names)


def main(argv: list[str] | None = None) -> int:
    args = vars(build_parser().parse_args(argv))
    out_dir = args.pop("out_dir")
    street, background = args.pop("street"), args.pop("background")
    small_objects = args.pop("small_objects")
    for name, value in args.items():
        if isinstance(value, list):
            args[name] = tuple(value)
    try:
        if street is not None:
            scene = _street_scene(street, args, background)
        elif small_objects:
            scene = _small_objects_scene(args, background)
        elif background is not None:
            raise ValueError("--background needs --street or --small-objects")
        else:
            only_small = [n for n, v in args.items() if v is not None and n not in SCENE_FIELDS]
            if only_small:
                raise ValueError(f"{_flags(only_small)} only apply with --small-objects")
            values: dict[str, typing.Any] = {
                name: field.default if args[name] is None else args[name]
                for name, field in SCENE_FIELDS.items()
            }
            config = SceneConfig(**values)
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
