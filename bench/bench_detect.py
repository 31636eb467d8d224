"""Benchmark of tracker_detect (area `detect`): SSIM map speed and the per-frame detector cost.

Run: python bench/bench_detect.py [--quick]   (or `make bench`). Prints a table and writes
out/bench/detect.json. Everything runs on ONE core (OpenCV and BLAS limited to one thread).

- ssim_map: two 768x576 grey frames of a synthetic scene, our map vs scikit-image's
  structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
  data_range=255, full=True), timed in the same run; targets <= 4 ms and >= 20x.
- detector: MotionDetector per frame on a 256x256 camera window sweeping over a 640x480 scene
  (frame k vs k-3), everything included (alignment, SSIM, mask, blobs); target <= 3 ms for the
  known shift, the estimated-shift modes reported.
- static camera: the registered detectors the node runs (`ssim` with the known (unchanging)
  pose, `ssim_background`, seed 004's `mog2`) per frame on the same frames of that scene, seen
  through a fixed 256x256 window and as the whole 640x480 frame (BGR in, blobs out; mog2 is a
  static-camera method, so it is timed here, not on the sweeping window).
- registration: the shift estimators alone, at the seed's 110x110 window and at 256x256.
- person model: the `person` detector (NanoDet, int8 as shipped) per 264x264 camera view (the
  surveillance graph's view at zoom 1) sweeping over vtest.avi, at input sizes 256 and 320 with
  onnxruntime, the float32 model at 256, and at 256 with OpenCV's DNN, beside `ssim_background`
  on the same views (colour in, boxes out), the surveillance graph's `person_motion` (both on
  every view; target <= 1.5x the model alone), and the other way to fuse them: the model on each
  motion blob's crop at 128 px.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
for _pkg in ("tracker_msgs", "tracker_detect", "tracker_ptz_sim"):
    sys.path.insert(0, str(ROOT / "src" / _pkg))

from skimage.metrics import structural_similarity  # noqa: E402

from tracker_detect.detector import CameraFrame  # noqa: E402
from tracker_detect.detectors import DETECTORS  # noqa: E402
from tracker_detect.motion.motion import DetectorConfig, MotionDetector  # noqa: E402
from tracker_detect.registration import (  # noqa: E402
    View,
    phase_correlation_shift,
    ssim_shift_search,
)
from tracker_detect.ssim import ssim_map  # noqa: E402
from tracker_msgs_py.geometry import Rect  # noqa: E402
from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene  # noqa: E402

OUT = ROOT / "out" / "bench" / "detect.json"


def median_ms(fn, repeats: int, warmup: int = 2) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def grey_frames(config: SceneConfig) -> np.ndarray:
    scene = generate_scene(config)
    return scene, np.stack([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in scene.frames])


def bench_ssim(quick: bool) -> dict:
    _, frames = grey_frames(SceneConfig(width=768, height=576, num_frames=4, num_objects=4, seed=1))
    x, y = frames[0], frames[3]
    ours = median_ms(lambda: ssim_map(x, y), 20 if quick else 200)
    reference = median_ms(
        lambda: structural_similarity(
            x,
            y,
            gaussian_weights=True,
            sigma=1.5,
            use_sample_covariance=False,
            data_range=255,
            full=True,
        ),
        3 if quick else 15,
        warmup=1,
    )
    _, full = structural_similarity(
        x,
        y,
        gaussian_weights=True,
        sigma=1.5,
        use_sample_covariance=False,
        data_range=255,
        full=True,
    )
    error = float(np.max(np.abs(ssim_map(x, y)[5:-5, 5:-5] - full[5:-5, 5:-5])))
    return {
        "size": "768x576",
        "ours_ms": ours,
        "skimage_ms": reference,
        "speedup": reference / ours,
        "max_abs_error_vs_skimage": error,
        "target_ms": 4.0,
        "target_speedup": 20.0,
    }


def sweep_windows(n: int, scene_w: int, scene_h: int, size: int, speed: int = 7) -> list:
    span = scene_w - size
    xs = np.abs((np.arange(n) * speed) % (2 * span) - span)
    ys = (scene_h - size) / 2 + 15 * np.sin(np.arange(n) / 4.0)
    return [(int(x), int(round(v))) for x, v in zip(xs, ys, strict=True)]


def bench_detector(quick: bool) -> dict:
    n = 20 if quick else 60
    _, frames = grey_frames(
        SceneConfig(width=640, height=480, num_frames=n, num_objects=6, noise_sigma=3.0, seed=2)
    )
    size = 256
    windows = sweep_windows(n, 640, 480, size)
    crops = [
        np.ascontiguousarray(frames[k, y : y + size, x : x + size])
        for k, (x, y) in enumerate(windows)
    ]
    views = [View(Rect(x, y, size, size), size, size) for x, y in windows]
    modes = {
        "known": (DetectorConfig(compensation="known"), True),
        "off": (DetectorConfig(compensation="off"), True),
        "phase_correlation": (DetectorConfig(compensation="phase_correlation"), False),
        "ssim_search (pyramid 2)": (DetectorConfig(compensation="ssim_search"), False),
        "ssim_search (exhaustive, seed)": (
            DetectorConfig(compensation="ssim_search", search_pyramid_levels=0),
            False,
        ),
        "known + double detection": (DetectorConfig(double_detection=True), True),
    }
    results = {}
    for name, (config, pose_known) in modes.items():
        limit = 8 if "exhaustive" in name else n
        times = []
        detector = MotionDetector(config)
        for k in range(limit):
            start = time.perf_counter()
            result = detector.process(crops[k], k * 100_000_000, views[k] if pose_known else None)
            elapsed = time.perf_counter() - start
            if result.compared:
                times.append(elapsed)
        results[name] = {"median_ms": 1e3 * statistics.median(times), "frames": len(times)}
    results["window"] = f"{size}x{size}"
    results["target_known_ms"] = 3.0
    return results


# (label, registered method, parameter overrides)
STATIC_METHODS = (
    ("ssim", "ssim", {}),
    ("ssim_background", "ssim_background", {}),
    ("ssim_background, register_reach 8", "ssim_background", {"register_reach": 8}),
    ("mog2", "mog2", {}),
)


def bench_static(quick: bool) -> dict:
    n = 20 if quick else 60
    scene = generate_scene(
        SceneConfig(width=640, height=480, num_frames=n, num_objects=6, noise_sigma=3.0, seed=2)
    )
    x, y, size = 192, 112, 256
    cases = {
        f"{size}x{size} window": (View(Rect(x, y, size, size), size, size), (x, y, size, size)),
        "640x480 frame": (View.identity(640, 480), (0, 0, 640, 480)),
    }
    results: dict = {}
    for label, (view, (x0, y0, w, h)) in cases.items():
        crops = [np.ascontiguousarray(f[y0 : y0 + h, x0 : x0 + w]) for f in scene.frames]
        for name, registered, overrides in STATIC_METHODS:
            method = DETECTORS.get(registered)
            detector = method.build({**method.defaults(), **overrides})
            times, blobs = [], 0
            for k, crop in enumerate(crops):
                frame = CameraFrame(k * 100_000_000, crop, view)
                start = time.perf_counter()
                result = detector.process(frame)
                elapsed = time.perf_counter() - start
                if result.compared:
                    times.append(elapsed)
                    blobs += len(result.blobs)
            results[f"{name} @ {label}"] = {
                "median_ms": 1e3 * statistics.median(times),
                "frames": len(times),
                "blobs_per_frame": blobs / len(times),
            }
    return results


def bench_registration(quick: bool) -> dict:
    _, frames = grey_frames(SceneConfig(width=400, height=400, num_frames=4, num_objects=3, seed=3))
    results = {}
    for size in (110, 256):
        prev = frames[0, 60 : 60 + size, 60 : 60 + size]
        curr = frames[3, 80 : 80 + size, 47 : 47 + size]  # true shift (-13, 20)
        cases = {
            "ssim_search exhaustive +-30 (seed)": lambda p=prev, c=curr: ssim_shift_search(p, c),
            "ssim_search pyramid 2": lambda p=prev, c=curr: ssim_shift_search(
                p, c, pyramid_levels=2
            ),
            "phase_correlation": lambda p=prev, c=curr: phase_correlation_shift(p, c),
        }
        for name, fn in cases.items():
            estimate = fn()
            repeats = 2 if "exhaustive" in name else (5 if quick else 30)
            results[f"{name} @ {size}"] = {
                "median_ms": median_ms(fn, repeats, warmup=1),
                "estimate": [round(estimate.dx, 3), round(estimate.dy, 3)],
                "truth": [-13, 20],
            }
    return results


PERSON_CASES = (
    ("person, 256 px input, onnxruntime", "person", {"input_size": 256}),
    ("person, 256 px, float32 (not quantised)", "person", {"precision": "float32"}),
    ("person, 320 px input, onnxruntime", "person", {"input_size": 320}),
    ("person, 256 px input, OpenCV DNN", "person", {"input_size": 256, "runtime": "opencv"}),
    ("ssim_background (the same views)", "ssim_background", {}),
    ("person_motion (the surveillance graph's)", "person_motion", {}),
)
CROP_INPUT = 128  # px, the person model's input for one blob's crop (a person fills it)
CROP_GROWTH = 0.25  # the blob's box grown by this x its longer side on each side


def bench_person(quick: bool) -> dict:
    """Per-view time of the person model on real people (vtest.avi), one thread."""
    from tracker_ptz_sim.bringup.sample import SampleUnavailableError, fetch_sample
    from tracker_ptz_sim.simulation.frame_sources import video_frames

    try:
        video = fetch_sample()
    except (SampleUnavailableError, OSError) as error:
        return {"skipped": f"vtest.avi is not available ({error})"}
    n, size = (20 if quick else 80), 264
    frames = [f for k, f in zip(range(n), video_frames(video), strict=False)]
    height, width = frames[0].shape[:2]
    windows = [(int(40 + (k * 5) % (width - size - 80)), 100) for k in range(n)]
    results: dict = {}
    for name, registered, overrides in PERSON_CASES:
        method = DETECTORS.get(registered)
        detector = method.build({**method.defaults(), **overrides})
        times, blobs = [], 0
        for k, (frame, (x, y)) in enumerate(zip(frames, windows, strict=True)):
            view = View(Rect(x, y, size, size), size, size)
            crop = np.ascontiguousarray(frame[y : y + size, x : x + size])
            start = time.perf_counter()
            result = detector.process(CameraFrame(k * 100_000_000, crop, view))
            elapsed = time.perf_counter() - start
            if result.compared and k >= 3:
                times.append(elapsed)
                blobs += len(result.blobs)
        results[name] = {
            "median_ms": 1e3 * statistics.median(times),
            "frames": len(times),
            "boxes_per_view": blobs / len(times),
        }
    results["ssim_background + its blobs' crops (the alternative)"] = bench_crops(frames, windows)
    return results


def bench_crops(frames: list, windows: list) -> dict:
    """The fusion's other way to look: the person model on each motion blob's crop (grown by
    CROP_GROWTH, at CROP_INPUT px) after the background detector, per view."""
    background = DETECTORS.get("ssim_background")
    detector = background.build(background.defaults())
    person = DETECTORS.get("person")
    model = person.build({**person.defaults(), "input_size": CROP_INPUT}).model
    size, times, crops = 264, [], 0
    for k, (frame, (x, y)) in enumerate(zip(frames, windows, strict=True)):
        view = View(Rect(x, y, size, size), size, size)
        image = np.ascontiguousarray(frame[y : y + size, x : x + size])
        start = time.perf_counter()
        result = detector.process(CameraFrame(k * 100_000_000, image, view))
        for blob in result.blobs:
            bx, by = blob.bbox.x - x, blob.bbox.y - y
            grow = CROP_GROWTH * max(blob.bbox.width, blob.bbox.height)
            x0, y0 = int(max(0, bx - grow)), int(max(0, by - grow))
            x1 = int(min(size, bx + blob.bbox.width + grow))
            y1 = int(min(size, by + blob.bbox.height + grow))
            if x1 - x0 >= 8 and y1 - y0 >= 8:
                model.detect(image[y0:y1, x0:x1])
                crops += 1
        elapsed = time.perf_counter() - start
        if result.compared and k >= 3:
            times.append(elapsed)
    return {
        "median_ms": 1e3 * statistics.median(times),
        "frames": len(times),
        "boxes_per_view": crops / max(1, len(times)),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (smoke run)")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    report = {
        "machine": {
            "python": platform.python_version(),
            "opencv": cv2.__version__,
            "cpu": platform.processor() or platform.machine(),
            "threads": 1,
        },
        "ssim_map": bench_ssim(args.quick),
        "detector": bench_detector(args.quick),
        "static": bench_static(args.quick),
        "registration": bench_registration(args.quick),
        "person": bench_person(args.quick),
    }
    s = report["ssim_map"]
    print("tracker_detect benchmark (one core)")
    print(
        f"\nSSIM map {s['size']}:  ours {s['ours_ms']:.2f} ms   scikit-image "
        f"{s['skimage_ms']:.1f} ms   speed-up {s['speedup']:.1f}x   "
        f"(max |diff| {s['max_abs_error_vs_skimage']:.1e}; targets <= 4 ms, >= 20x)"
    )
    print(f"\nDetector per frame, {report['detector']['window']} window (target known <= 3 ms):")
    for name, value in report["detector"].items():
        if isinstance(value, dict):
            print(f"  {name:34s} {value['median_ms']:8.2f} ms  ({value['frames']} frames)")
    print("\nStatic camera, registered detectors per frame (same frames, colour in; 6 objects):")
    for name, value in report["static"].items():
        print(
            f"  {name:50s} {value['median_ms']:8.2f} ms  ({value['frames']} frames, "
            f"{value['blobs_per_frame']:.1f} blobs/frame)"
        )
    print("\nShift estimators alone (true shift (-13, 20)):")
    for name, value in report["registration"].items():
        print(f"  {name:44s} {value['median_ms']:8.2f} ms  -> {value['estimate']}")
    print("\nPerson model per 264x264 view of vtest.avi (one thread), beside the SSIM detector:")
    for name, value in report["person"].items():
        if name == "skipped":
            print(f"  skipped: {value}")
            continue
        print(
            f"  {name:52s} {value['median_ms']:8.2f} ms  ({value['frames']} views, "
            f"{value['boxes_per_view']:.1f} boxes/view)"
        )
    person = report["person"]
    if "skipped" not in person:
        fused = person["person_motion (the surveillance graph's)"]["median_ms"]
        alone = person["person, 256 px input, onnxruntime"]["median_ms"]
        print(f"  person_motion / the model alone: {fused / alone:.2f}x (target <= 1.5x)")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(report, indent=1))
    print(f"\nwrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
