"""Quantise the person model to int8, once, by hand: nanodet.onnx -> nanodet_int8.onnx.

Two steps, because the suite's environment has onnxruntime without `onnx` (which onnxruntime's
quantisation tool needs) and the throwaway venv has no suite:

    # 1. in the suite's environment: camera views of the development scenes of real people
    source scripts/env.sh
    python scripts/quantize_person_model.py views /tmp/person_views.npz
    # 2. in a throwaway venv: calibrate and quantise
    python3 -m venv /tmp/quantize
    /tmp/quantize/bin/pip install onnx==1.23.2 onnxruntime==1.32.0 numpy
    /tmp/quantize/bin/python scripts/quantize_person_model.py quantize /tmp/person_views.npz

Never run at setup. What it does:
1. `views`: 240 camera views (264 x 198 px, zoom 1-2.9 over random frames, as the simulated
   pan-tilt camera sees them) of the *development* scenes of real people (`real_*`; never the
   held-out ones, never the annotated clip), as the model's input blobs (`PersonModel.blob`, 256
   px input). The scenes render as `benchmark` renders them (cached in out/benchmark/scenes).
2. `quantize`: onnxruntime's static quantisation in QDQ form, the activation ranges from those
   views (min-max), weights int8 per output channel with 7-bit range (`reduce_range`: no
   saturation on CPUs without VNNI), activations uint8. Only the convolutions and their leaky
   ReLUs are quantised: the max-pool's padding is -inf (a range no 8-bit scale holds; quantising
   it leaves no box at all), and the head's decoding stays float.
3. Writes `nanodet_int8.onnx` and updates SHA256SUMS.

Measured on this 2-core machine (onnxruntime 1.32, one thread, 256 x 192 input): 6.3 ms a view
against 15.6 for the float model, and the boxes of 97 % of the float model's people within IoU
0.7 on vtest.avi's views; the benchmark's figures of both are in docs/results/people.md.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

MODELS = Path(__file__).resolve().parents[1] / "src" / "tracker_detect" / "models"
SOURCE, TARGET = "nanodet.onnx", "nanodet_int8.onnx"
VIEWS_PER_SCENE = 40
VIEW_SIZE = (264, 198)  # the simulated camera's image, px
ZOOM = (1.0, 2.9)
# quantising these leaves no box (the padding before the max-pool is -inf)
NOT_QUANTISED = ["PartitionedCall/PadV2", "PartitionedCall/MaxPool2d"]


def camera_views(seed: int = 0) -> np.ndarray:
    """(N, 3, 192, 256) float32 model inputs of the development scenes' camera views."""
    import cv2

    from tracker_detect.person.person import PersonConfig, PersonModel
    from tracker_ptz_sim.bringup import benchmark
    from tracker_ptz_sim.simulation import street
    from tracker_ptz_sim.simulation.frame_sources import video_frames

    model = PersonModel(PersonConfig())
    background, _ = benchmark.background_image("vtest")
    cache = Path("out/benchmark/scenes")
    rng = np.random.default_rng(seed)
    blobs = []
    for name, config in street.REAL_PEOPLE_PRESETS.items():
        if benchmark.scene_set(name) != "development":
            continue
        root = benchmark.prepare_scene(name, config, background, cache)
        frames = list(video_frames(root / "video.avi"))
        height, width = frames[0].shape[:2]
        for index in rng.choice(len(frames), VIEWS_PER_SCENE, replace=False):
            w = int(width / rng.uniform(*ZOOM))
            h = int(w * VIEW_SIZE[1] / VIEW_SIZE[0])
            x, y = rng.integers(0, width - w + 1), rng.integers(0, height - h + 1)
            view = cv2.resize(frames[index][y : y + h, x : x + w], VIEW_SIZE, cv2.INTER_AREA)
            blobs.append(model.blob(view)[0])
    return np.concatenate(blobs)


def quantize(views: np.ndarray) -> Path:
    from onnxruntime.quantization import (
        CalibrationDataReader,
        CalibrationMethod,
        QuantFormat,
        QuantType,
        quantize_static,
    )
    from onnxruntime.quantization.shape_inference import quant_pre_process

    class Views(CalibrationDataReader):
        def __init__(self) -> None:
            self.left = iter(views)

        def get_next(self) -> dict[str, np.ndarray] | None:
            view = next(self.left, None)
            return None if view is None else {"input_1:0": view[None]}

    prepared = MODELS / "nanodet_prepared.onnx"  # weights folded to float32, shapes inferred
    target = MODELS / TARGET
    try:
        quant_pre_process(str(MODELS / SOURCE), str(prepared), skip_symbolic_shape=True)
        quantize_static(
            str(prepared),
            str(target),
            Views(),
            quant_format=QuantFormat.QDQ,
            per_channel=True,
            reduce_range=True,
            activation_type=QuantType.QUInt8,
            weight_type=QuantType.QInt8,
            calibrate_method=CalibrationMethod.MinMax,
            op_types_to_quantize=["Conv", "LeakyRelu"],
            nodes_to_exclude=NOT_QUANTISED,
        )
    finally:
        prepared.unlink(missing_ok=True)
    return target


def write_checksum(path: Path) -> None:
    sums = path.parent / "SHA256SUMS"
    lines = [line for line in sums.read_text().splitlines() if not line.endswith(f"  {path.name}")]
    lines.append(f"{hashlib.sha256(path.read_bytes()).hexdigest()}  {path.name}")
    sums.write_text("\n".join(sorted(lines, key=lambda line: line.split()[1])) + "\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("step", choices=("views", "quantize"))
    parser.add_argument("views", type=Path, help="the .npz of calibration views")
    args = parser.parse_args(argv)
    if args.step == "views":
        views = camera_views()
        np.savez_compressed(args.views, views=views)
        print(f"{len(views)} views -> {args.views}")
        return 0
    target = quantize(np.load(args.views)["views"])
    write_checksum(target)
    print(f"wrote {target} ({target.stat().st_size / 1e6:.1f} MB) and SHA256SUMS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
