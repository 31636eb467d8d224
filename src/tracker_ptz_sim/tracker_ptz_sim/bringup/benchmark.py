"""benchmark: the suite's accuracy of record, on real people with ground truth.

    benchmark                      the annotated clip and the real-people scenes, every
                                   configuration, in process; prints the tables
    benchmark --graph vtest        also the annotated clip through the node graph (make benchmark)
    benchmark --graph              ... every scene through the node graph
    benchmark --scenes vtest --configs suite person
    benchmark --scenes walkers groups --seeds 12   the drawn-figure scenes (a side table)
    benchmark --scenes small_objects --configs gmphd --graph

The scenes of record (`DEFAULT_SCENES`):
- `vtest`: OpenCV's vtest.avi (real pedestrians, 795 frames) with its reviewed annotation
  (annotations/vtest/, how it was made in its README), seen through the simulated pan-tilt camera.
- `real_<kind>` and `heldout_<kind>` (`simulation.street.REAL_PEOPLE_PRESETS`): people of that
  clip, cut out frame by frame with their real gait (`simulation.real_people`), walking the
  street generator's paths over the clip's background: walkers, groups walking together, pairs
  crossing, people who stop, people passing behind boards, a shaking camera; all with fluttering
  tape, foliage, flicker, lighting drift, noise and JPEG compression. Development scenes are made
  of two thirds of the clip's people, held-out scenes of the other third, at other seeds: tune on
  the first, report the second apart and never tune on it. Ground truth is every person's visible
  box, from the pasted masks.

The drawn-figure street scenes (`simulation.street.STREET_PRESETS`: articulated figures with a
gait) and the small-object scenes of seed 004 (`simulation.small_objects`: 40 insects and birds of
10-30 px over a generated ground, 200 frames at 25 frames/s; hidden movers keep their box with
conf 0, ignored) run when named.

Each configuration is a graph with `node.param` overrides on its parameter files, scored on the
scenes of its kind (`Configuration.scenes`). On street scenes: `suite` is the surveillance graph as
shipped; `seed000` is seed 000's own mode (SSIM of frame k against k-3, the seed's tracker preset,
the camera jumping straight to the target); `colour` is the colour graph (seed 001: motion hands its
target over to CamShift, which the camera follows; one track, so its MOT scores count one person);
`particles` is the surveillance graph with seed 003's `colour_particles` tracker, `occupancy` with
seed 002's `occupancy_particles` (its detector without the side-by-side cut, stopped people
healing at the usual rate), `gmphd_ssim` with seed 004's GM-PHD; `person` is the learned baseline:
the `person` detector (NanoDet on every camera image) and the plain gated-Hungarian tracker (its
preset, without the rules config/surveillance.yaml adds for motion blobs). On small-object
scenes: `gmphd` is the small-objects graph (seed 004: a fixed camera over the whole scene, MOG2,
the GM-PHD tracker with occlusion handling); `gmphd_plain` the same without occlusion handling.

Scores (`evaluation.scoring`): CLEAR MOT, IDF1 and HOTA at IoU >= 0.5 in the camera view and over
the whole scene, and the pan-tilt figures; on small-object scenes also seed 004's scores on box
centres (`evaluation.centre_scores`: OSPA with c = 5 and 10 px, MOTA / IDF1 with a 10 px match,
missed occlusions), in a second table. Writes to --out (default out/benchmark): results.json,
table.md, and per run tracks.txt, evaluation.json and plots.png (centring error, pan/tilt, followed
ids over time).

Graph runs talk on a ROS domain of their own (`--ros-domain-id`, default: one chosen from the
process id, never the environment's) with localhost-only discovery: a demo or another graph on
the machine's domain would otherwise feed its messages into the lockstep replay and change the
numbers of record.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import shutil
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from tracker_filter.gated_hungarian.config import PRESETS
from tracker_msgs_py import stop_signals
from tracker_msgs_py.codec import frame_stamp_ns
from tracker_msgs_py.package_files import package_data
from tracker_msgs_py.ros_domain import private_domain_id
from tracker_ptz_sim.bringup import pipeline
from tracker_ptz_sim.bringup.graph import load_graph, node_parameters, unknown_override_nodes
from tracker_ptz_sim.evaluation import error_classes, run_files, scoring
from tracker_ptz_sim.evaluation.centre_scores import OSPA_CUTOFFS, ospa_key
from tracker_ptz_sim.simulation import (
    camera_effects,
    ground_truth,
    real_people,
    small_objects,
    street,
)
from tracker_ptz_sim.simulation.frame_sources import video_frames
from tracker_ptz_sim.simulation.scene_files import (
    GT_PATH,
    META_NAME,
    label_reader,
    load_scene,
    write_scene,
)
from tracker_ptz_sim.simulation.scenes import Scene


def _tracker_settings(graph_name: str) -> tuple[str, ...]:
    """The tracker parameters the graph's params files set on top of the tracker's preset (a
    configuration on another preset resets them to that preset's values)."""
    graph = load_graph(graph_name)
    return tuple(
        name for name in node_parameters(graph.params_files, "tracker") if name in PRESETS["multi"]
    )


#: The small-object scenes (seed 004), by name; their seeds (7, 8, 9) are not the ones
#: config/small_objects.yaml was tuned on (1-6).
SMALL_OBJECT_PRESETS: dict[str, small_objects.SmallObjectsConfig] = {
    # 40 movers of 10-30 px over 200 frames, 25-35 in view at a time, 5 forced crossings, 3 occluders
    "small_objects": small_objects.SmallObjectsConfig(seed=7),
}


@dataclass(frozen=True)
class AnnotatedClip:
    """A real clip and its reviewed ground truth (`annotation`): annotations/<name>/ of this
    package holds gt/gt.txt and seqinfo.ini; the clip is the sample vtest.avi."""

    name: str
    seed: ClassVar[int] = 0  # one clip, not a family of scenes: --seeds does not apply

    @property
    def folder(self) -> Path:
        return package_data("tracker_ptz_sim", "annotations") / self.name

    @property
    def gt(self) -> Path:
        return self.folder / GT_PATH


#: The annotated real clips, by name.
CLIPS: dict[str, AnnotatedClip] = {"vtest": AnnotatedClip("vtest")}
SceneConfig = street.StreetConfig | small_objects.SmallObjectsConfig | AnnotatedClip
#: Every scene by name: the annotated clip, the scenes of real people (development, held-out),
#: the drawn-figure street scenes, the small-object scenes.
SCENES: dict[str, SceneConfig] = {
    **CLIPS,
    **street.REAL_PEOPLE_PRESETS,
    **street.STREET_PRESETS,
    **SMALL_OBJECT_PRESETS,
}
#: What `benchmark` runs when no --scenes are named: real people only (the accuracy of record).
DEFAULT_SCENES = (*CLIPS, *street.REAL_PEOPLE_PRESETS)
STREET, SMALL_OBJECTS = "street", "small_objects"  # the kinds of scene


def scene_kind(config: SceneConfig) -> str:
    """Which configurations run on it: the small-object ones, or the street ones (people)."""
    return SMALL_OBJECTS if isinstance(config, small_objects.SmallObjectsConfig) else STREET


def scene_set(name: str) -> str:
    """The table's groups: "annotated clip", "development", "held-out", "drawn figures" or
    "small objects"."""
    config = SCENES[name]
    if isinstance(config, AnnotatedClip):
        return "annotated clip"
    if isinstance(config, small_objects.SmallObjectsConfig):
        return "small objects"
    return {"development": "development", "held_out": "held-out"}.get(
        config.people, "drawn figures"
    )


@dataclass(frozen=True)
class Configuration:
    """A graph (`graph.GRAPHS`) and node -> parameter -> value overrides on its params files,
    scored on the scenes of kind `scenes` (STREET or SMALL_OBJECTS)."""

    graph: str = "surveillance"
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)
    scenes: str = STREET


#: gm_phd for people at 10 frames/s in scene px (its defaults are for small movers at 25).
GMPHD_PEOPLE = {
    "measurement_noise": 6.0,  # px: a person's blob centroid jitters with the gait
    "process_noise": 150.0,  # px/s^2
    "object_size": 40.0,  # px: the possible-occlusion radius without measured boxes
    "max_birth_speed": 300.0,  # px/s
    "clutter_rate": 2.0,  # false blobs per frame (flutter the flicker map misses)
}

#: seed 002's tracker on the motion graph. It tracks better with stopped people healing at the
#: detector's heal_rate (0.05) like everything else (README, seed 002).
OCCUPANCY: dict[str, dict[str, Any]] = {
    "tracker": {"method": "occupancy_particles"},
    "ssim_detector": {"stopped_heal_rate": 0.05},
}

#: Configurations compared. A new tracker or detector joins the benchmark with one line here.
CONFIGURATIONS: dict[str, Configuration] = {
    # the surveillance graph as shipped: the person_motion detector, the byte tracker, people
    "suite": Configuration(),
    # the same nodes without the person model: motion blobs, the rules made for them
    # (config/motion.yaml), the gated-Hungarian tracker; the camera follows what walks
    "motion": Configuration("motion"),
    "seed000": Configuration(
        "motion",
        overrides={
            "ssim_detector": {"method": "ssim"},
            # the seed's tracker preset, also for what motion.yaml sets on top of presets
            "tracker": {"preset": "seed000"}
            | {name: PRESETS["seed000"][name] for name in _tracker_settings("motion")},
            "ptz_controller": {"mode": "direct", "zoom_control": False},
            "ptz_camera": {"min_zoom": 1.0},
        },
    ),
    # seed 001: motion hands its target over to CamShift, which the camera follows (one track)
    "colour": Configuration("colour"),
    # seed 003: the motion graph with one colour particle filter per target as its tracker
    "particles": Configuration("motion", {"tracker": {"method": "colour_particles"}}),
    # seed 002: one particle filter per person on the detector's motion mask (README, seed 002)
    "occupancy": Configuration("motion", OCCUPANCY),
    # seed 004: a fixed camera over many small movers, MOG2 and the GM-PHD tracker
    "gmphd": Configuration("small_objects", scenes=SMALL_OBJECTS),
    # the plain pipeline: the person model (NanoDet) alone on every camera image, its confident
    # boxes (its default score 0.5), and the plain gated-Hungarian tracker (its preset): the
    # learned floor to beat
    "person": Configuration(
        overrides={
            "ssim_detector": {"method": "person", "score_threshold": 0.5},
            "tracker": {"method": "gated_hungarian"}
            | {name: PRESETS["multi"][name] for name in _tracker_settings("surveillance")},
        }
    ),
    # the suite without motion: the person model alone (weak boxes too) and the byte tracker
    "person_byte": Configuration(
        overrides={"ssim_detector": {"method": "person", "score_threshold": 0.2}}
    ),
    # seed 004's GM-PHD tracker on the motion graph's SSIM blobs, under the moving camera
    "gmphd_ssim": Configuration("motion", {"tracker": {"method": "gm_phd"} | GMPHD_PEOPLE}),
    # ... without seed 004's occlusion handling (plain GM-PHD with Hungarian labels)
    "gmphd_plain": Configuration(
        "small_objects", {"tracker": {"occlusion_handling": False}}, scenes=SMALL_OBJECTS
    ),
}
PATHS = ("in-process", "graph")


@dataclass(frozen=True)
class RunScores:
    scene: str
    configuration: str
    path: str
    frames: int
    seconds: float  # wall time of the run (rendering the scene excluded)
    scores: dict[str, Any]
    seed: int = 0  # the scene's seed


def background_image(kind: str) -> tuple[np.ndarray | None, str]:
    """The scenes' background: the sample clip's median (`vtest`) or None (generated), and what
    it is in words."""
    if kind == "vtest":
        from tracker_ptz_sim.bringup.sample import SampleUnavailableError, fetch_sample

        try:
            return street.median_background(fetch_sample()), "median of vtest.avi"
        except (SampleUnavailableError, OSError) as error:
            print(f"vtest.avi is not available ({error}): generated backgrounds", file=sys.stderr)
    return None, "generated plaza"


class RealPeople:
    """The cut-outs of the annotated vtest.avi's people (`real_people`), made on first use."""

    def __init__(self) -> None:
        self._library: real_people.CutoutLibrary | None = None

    @property
    def gt(self) -> Path:
        return CLIPS["vtest"].gt

    def library(self) -> real_people.CutoutLibrary:
        if self._library is None:
            from tracker_ptz_sim.bringup.sample import fetch_sample

            video = fetch_sample()
            print("cutting out the annotated people of vtest.avi ...", flush=True)
            self._library = real_people.load_library(
                video, self.gt, street.median_background(video), real_people.CutoutConfig()
            )
        return self._library


def prepare_scene(
    name: str,
    config: street.StreetConfig | small_objects.SmallObjectsConfig,
    background: np.ndarray | None,
    cache: Path,
    people: RealPeople | None = None,
) -> Path:
    """The scene directory for `config` (a street or small-object scene) over `background`,
    rendered once and cached by content (the generators' sources included: a changed generator
    renders its scenes anew; scenes of real people also by the annotation they are cut from)."""
    small = isinstance(config, small_objects.SmallObjectsConfig)
    real = isinstance(config, street.StreetConfig) and config.people != "drawn"
    sources = (street, camera_effects, small_objects if small else real_people)
    key = hashlib.sha256(
        json.dumps(asdict(config), sort_keys=True).encode()
        + (background.tobytes() if background is not None else b"generated")
        + b"".join(Path(module.__file__ or "").read_bytes() for module in sources)
        + ((people or RealPeople()).gt.read_bytes() if real else b"")
    ).hexdigest()[:12]
    root = cache / f"{name}-{key}"
    if not (root / META_NAME).exists():
        print(f"rendering scene {name} ({config.num_frames} frames) ...", flush=True)
        scene: Scene
        if isinstance(config, small_objects.SmallObjectsConfig):
            scene = small_objects.generate_small_objects(config, background)
        else:
            cutouts = (people or RealPeople()).library() if real else None
            scene = street.generate_street(config, background, cutouts)
        _write_whole(scene, root)
    return root


@dataclass(frozen=True)
class ClipReplay:
    """A real clip as `run_in_process` replays it: its frames, read anew each time."""

    video: Path
    fps: float
    num_frames: int

    @property
    def frames(self) -> Iterator[np.ndarray]:
        return video_frames(self.video)

    def stamps_ns(self) -> list[int]:
        return [frame_stamp_ns(i, self.fps) for i in range(self.num_frames)]


def prepare_clip(clip: AnnotatedClip, cache: Path) -> tuple[Path, ClipReplay]:
    """A scene directory for the annotated clip (its gt/gt.txt and a scene.json naming the
    clip's video) and its replay."""
    from tracker_ptz_sim.bringup.sample import fetch_sample

    video = fetch_sample()
    info = ground_truth.read_seqinfo(clip.folder)
    root = cache / f"{clip.name}-annotated"
    (root / "gt").mkdir(parents=True, exist_ok=True)
    shutil.copyfile(clip.gt, root / GT_PATH)
    meta = {"generator": "clip", "video": str(video), "num_frames": info.length, "fps": info.fps}
    (root / META_NAME).write_text(json.dumps(meta, indent=2) + "\n")
    return root, ClipReplay(video, info.fps, info.length)


def _write_whole(scene: Scene, root: Path) -> None:
    """Write `scene` to `root` so that no reader ever sees part of it: into a directory of this
    process's own, renamed into place (two benchmarks sharing a cache render the same scene at
    once; one read the other's half-written video). A `root` without its metadata is what an
    interrupted write left before: replaced."""
    staging = root.with_name(f".{root.name}.{os.getpid()}")
    shutil.rmtree(staging, ignore_errors=True)
    write_scene(scene, staging)
    if root.exists() and not (root / META_NAME).exists():
        shutil.rmtree(root, ignore_errors=True)
    try:
        staging.rename(root)
    except OSError:
        shutil.rmtree(staging, ignore_errors=True)
        if not (root / META_NAME).exists():  # not another process's scene put in place first
            raise


Replay = Scene | ClipReplay


def run_in_process(scene: Replay, settings: pipeline.PipelineSettings) -> scoring.RunTrace:
    steps = pipeline.run(scene.frames, scene.stamps_ns(), settings)
    return scoring.trace_from_steps(steps, scene.fps, settings.followed_labels)


def run_graph(
    scene_dir: Path, graph_name: str, overrides: dict[str, dict[str, Any]], out: Path
) -> scoring.RunTrace:
    from tracker_ptz_sim.bringup import demo
    from tracker_ptz_sim.evaluation import run_report
    from tracker_ptz_sim.simulation.scene_files import scene_video

    with stop_signals.deferred():  # the runner stops the nodes and closes the bag itself
        result = demo.run_graph(
            load_graph(graph_name),
            scene_video(scene_dir),
            out,
            overrides,
            demo.install_space(),
            1800.0,
        )
    if not result.complete:
        raise RuntimeError(f"the graph run is incomplete: {'; '.join(result.problems)}")
    labels = pipeline.PipelineSettings.from_graph(load_graph(graph_name), overrides).followed_labels
    return scoring.trace_from_frames(run_report.collect(result.bag), labels)


def benchmark_one(
    scene_name: str,
    scene_dir: Path,
    scene: Replay,
    configuration: str,
    graph_name: str,
    overrides: dict[str, dict[str, Any]],
    path: str,
    out: Path,
    centres: bool = False,
) -> RunScores:
    run_dir = out / "runs" / f"{scene_name}-{configuration}-{path}"
    run_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    if path == "graph":
        trace = run_graph(scene_dir, graph_name, overrides, run_dir)
    else:
        settings = pipeline.PipelineSettings.from_graph(load_graph(graph_name), overrides)
        trace = run_in_process(scene, settings)
    seconds = time.perf_counter() - started
    title = f"{scene_name}, {configuration}, {path}"
    gt = scene_dir / "gt" / "gt.txt"
    scores = run_files.write_evaluation(trace, gt, run_dir, title, label_reader(scene_dir), centres)
    return RunScores(scene_name, configuration, path, scores["frames"], seconds, scores)


def _merged(
    base: dict[str, dict[str, Any]], extra: dict[str, dict[str, Any]]
) -> dict[str, dict[str, Any]]:
    return {node: {**base.get(node, {}), **extra.get(node, {})} for node in {*base, *extra}}


def _groups(
    results: list[RunScores], key: Callable[[RunScores], str] = lambda r: r.scene
) -> dict[tuple[str, str, str], list[RunScores]]:
    """The runs by (key: the scene preset unless given, configuration, path), in first-run order."""
    groups: dict[tuple[str, str, str], list[RunScores]] = {}
    for r in results:
        groups.setdefault((key(r), r.configuration, r.path), []).append(r)
    return groups


def _mean(runs: list[RunScores], part: str, name: str) -> float:
    values = [r.scores[part][name] for r in runs]
    finite = [v for v in values if v is not None and v == v]
    return float(np.mean(finite)) if finite else math.nan


def _speed(runs: list[RunScores]) -> float:
    return sum(r.frames for r in runs) / sum(r.seconds for r in runs)


def table(results: list[RunScores]) -> str:
    """The results as Markdown tables: per set of scenes (`set_table`), then per scene preset,
    configuration and path, the mean over the preset's seeds (object changes summed); why boxes
    missed (`error_table`); the runs scored on box centres (small-object scenes) again in a
    fourth table, `centre_table`."""
    centred = [r for r in results if "centres" in r.scores]
    return (
        set_table(results)
        + "\n\n"
        + main_table(results)
        + "\n\n"
        + error_table(results)
        + ("\n\n" + centre_table(centred) if centred else "")
    )


SET_ORDER = ("annotated clip", "development", "held-out", "drawn figures", "small objects")


def set_table(results: list[RunScores]) -> str:
    """Per set of scenes (`scene_set`), configuration and path: the mean over its runs."""
    header = (
        "| scenes | configuration | path | runs | view MOTA | view IDF1 | view HOTA | recall | "
        "precision | id switches | scene MOTA | scene IDF1 | target on object | "
        "object changes (unexplained) |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    groups = _groups(results, lambda r: scene_set(r.scene))
    order = {name: k for k, name in enumerate(SET_ORDER)}
    for (kind, configuration, path), runs in sorted(
        groups.items(), key=lambda item: order[item[0][0]]
    ):

        def mean(part: str, name: str, runs: list[RunScores] = runs) -> float:
            return _mean(runs, part, name)

        switches = sum(r.scores["in_view"]["id_switches"] for r in runs)
        changes = sum(r.scores["pan_tilt"]["followed_changes"] for r in runs)
        unexplained = sum(r.scores["pan_tilt"]["unexplained_changes"] for r in runs)
        lines.append(
            f"| {kind} | {configuration} | {path} | {len(runs)} | {mean('in_view', 'mota'):.3f} | "
            f"{mean('in_view', 'idf1'):.3f} | {mean('in_view', 'hota'):.3f} | "
            f"{mean('in_view', 'recall'):.3f} | {mean('in_view', 'precision'):.3f} | {switches} | "
            f"{mean('whole_scene', 'mota'):.3f} | {mean('whole_scene', 'idf1'):.3f} | "
            f"{100 * mean('pan_tilt', 'on_object_share'):.1f} % | {changes} ({unexplained}) |"
        )
    return (
        "Per set of scenes (the annotated clip; scenes of real people, development and held-out "
        "people apart; drawn figures; small objects): the mean over the set's runs, IoU >= 0.5, "
        "in the camera's view unless 'scene'; id switches and object changes summed.\n\n"
        + "\n".join(lines)
    )


def error_table(results: list[RunScores]) -> str:
    """In view, every miss and false positive put in one class (`evaluation.error_classes`),
    summed over the preset's seeds."""
    names = (*error_classes.MISSES, *error_classes.FALSE_POSITIVES)
    header = (
        "| scene | configuration | path | people | misses: "
        + " | ".join(n.replace("_", " ") for n in error_classes.MISSES)
        + " | false: "
        + " | ".join(n.replace("_", " ") for n in error_classes.FALSE_POSITIVES)
        + " |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for (scene, configuration, path), runs in _groups(results).items():
        total = {n: sum(r.scores["errors_in_view"][n] for r in runs) for n in ("people", *names)}
        lines.append(
            f"| {scene} | {configuration} | {path} | {total['people']} | "
            + " | ".join(str(total[n]) for n in names)
            + " |"
        )
    return (
        "Why boxes missed, in view (`evaluation.error_classes`: frame by frame at IoU 0.5; a miss "
        "is a reported box shared with another person, a tentative track's, a good detection "
        "not reported, a detection box too big / too small / off at IoU 0.1-0.5, or no "
        "detection; a false box overlaps a person at IoU >= 0.1 or nothing).\n\n" + "\n".join(lines)
    )


def main_table(results: list[RunScores]) -> str:
    """Every run's IoU >= 0.5 scores and pan-tilt figures (`table`)."""
    header = (
        "| scene | configuration | path | runs | view MOTA | view IDF1 | view HOTA | scene MOTA | "
        "scene IDF1 | scene HOTA | target on object | object changes (unexplained) | "
        "centring error | frames/s |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for (scene, configuration, path), runs in _groups(results).items():

        def mean(part: str, name: str, runs: list[RunScores] = runs) -> float:
            return _mean(runs, part, name)

        changes = sum(r.scores["pan_tilt"]["followed_changes"] for r in runs)
        unexplained = sum(r.scores["pan_tilt"]["unexplained_changes"] for r in runs)
        error = mean("pan_tilt", "mean_center_error_px")
        speed = _speed(runs)
        lines.append(
            f"| {scene} | {configuration} | {path} | {len(runs)} | {mean('in_view', 'mota'):.3f} | "
            f"{mean('in_view', 'idf1'):.3f} | {mean('in_view', 'hota'):.3f} | "
            f"{mean('whole_scene', 'mota'):.3f} | {mean('whole_scene', 'idf1'):.3f} | "
            f"{mean('whole_scene', 'hota'):.3f} | "
            f"{100 * mean('pan_tilt', 'on_object_share'):.1f} % | {changes} ({unexplained}) | "
            + ("n/a" if math.isnan(error) else f"{error:.0f} px")
            + f" | {speed:.1f} |"
        )
    return "\n".join(lines)


def centre_table(results: list[RunScores]) -> str:
    """Seed 004's scores on box centres (`evaluation.centre_scores`, conf-0 movers ignored) of the
    runs that have them: OSPA (p = 2) per cut-off, and CLEAR MOT with a centre-distance match."""
    ospa = "".join(f"OSPA c={c:g} px | " for c in OSPA_CUTOFFS)
    header = (
        "| scene | configuration | path | runs | centre MOTA | centre IDF1 | id switches | "
        f"recall | false alarms | missed occlusions | {ospa}frames/s |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for (scene, configuration, path), runs in _groups(results).items():

        def mean(name: str, runs: list[RunScores] = runs) -> float:
            return _mean(runs, "centres", name)

        switches = sum(r.scores["centres"]["id_switches"] for r in runs)
        missed = sum(r.scores["centres"]["missed_occlusions"] for r in runs)
        occlusions = sum(r.scores["centres"]["occlusions"] for r in runs)
        lines.append(
            f"| {scene} | {configuration} | {path} | {len(runs)} | {mean('mota'):.3f} | "
            f"{mean('idf1'):.3f} | {switches} | {mean('recall'):.3f} | "
            f"{mean('false_alarm_rate'):.3f} | {missed}/{occlusions} | "
            + "".join(f"{mean(ospa_key(c)):.2f} | " for c in OSPA_CUTOFFS)
            + f"{_speed(runs):.1f} |"
        )
    match = results[0].scores["centres"]["match_distance_px"] if results else 0.0
    return (
        "Box centres (seed 004; ground truth with conf 0, i.e. hidden or barely visible movers, "
        f"ignored): a match within {match:g} px; false alarms = unmatched tracks / tracks; an "
        "occlusion is missed when the track before it is not back within 3 frames; OSPA in px, "
        "mean over frames.\n\n" + "\n".join(lines)
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="benchmark", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", type=Path, default=Path("out/benchmark"))
    parser.add_argument("--scenes", nargs="+", choices=sorted(SCENES))
    parser.add_argument("--configs", nargs="+", choices=sorted(CONFIGURATIONS))
    parser.add_argument(
        "--graph",
        nargs="*",
        metavar="SCENE",
        help="also run through the node graph: the scenes named (make benchmark: vtest), or with "
        "none named every scene",
    )
    parser.add_argument("--frames", type=int, help="shorten every scene to this many frames")
    parser.add_argument(
        "--seeds", type=int, default=2, help="scenes per preset (its seed, seed + 1, ...)"
    )
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help="skip this many scenes of each preset (--seeds 12 --first-seed 12: twelve scenes "
        "that the README's rows of record, the first twelve, do not include)",
    )
    parser.add_argument(
        "--background",
        choices=("vtest", "generated"),
        default="vtest",
        help="street scenes' background (small-object scenes: always a generated ground)",
    )
    parser.add_argument(
        "--ros-domain-id",
        type=int,
        help="ROS_DOMAIN_ID of the graph runs (default: a private one, localhost only)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NODE.PARAM=VALUE",
        help="override a parameter in every configuration",
    )
    args = parser.parse_args(argv)
    if args.first_seed < 0:
        parser.error("--first-seed must be >= 0")
    from tracker_ptz_sim.bringup.demo import parse_overrides

    extra = parse_overrides(args.set)
    scene_names = args.scenes or list(DEFAULT_SCENES)
    configurations = args.configs or list(CONFIGURATIONS)
    runs = {
        name: [c for c in configurations if CONFIGURATIONS[c].scenes == scene_kind(SCENES[name])]
        for name in scene_names
    }
    if not any(runs.values()):
        parser.error(
            "no configuration for these scenes: street scenes take "
            + ", ".join(c for c, v in CONFIGURATIONS.items() if v.scenes == STREET)
            + "; small-object scenes "
            + ", ".join(c for c, v in CONFIGURATIONS.items() if v.scenes == SMALL_OBJECTS)
        )
    graphs = {CONFIGURATIONS[c].graph for chosen in runs.values() for c in chosen}
    problem = unknown_override_nodes(extra, [load_graph(name) for name in sorted(graphs)])
    if problem:
        parser.error(problem)
    if args.graph is not None:
        unknown = sorted(set(args.graph) - set(scene_names))
        if unknown:
            parser.error(f"--graph names scenes not run: {', '.join(unknown)}")
        _isolate_ros(args.ros_domain_id)
    args.out.mkdir(parents=True, exist_ok=True)
    streets = any(scene_kind(SCENES[name]) == STREET and runs[name] for name in scene_names)
    background, described = background_image(args.background) if streets else (None, "")
    results: list[RunScores] = []
    failures: list[str] = []
    try:
        _run_all(args, scene_names, runs, background, extra, results, failures)
        interrupted = None
    except KeyboardInterrupt:  # Ctrl-C: the table of what was measured so far
        interrupted = stop_signals.received() or "SIGINT"
    text = table(results)
    over = f"Street scenes over: {described}; " if described else ""
    note = f"{over}{args.out}/runs/* hold each run's tracks, scores and plots."
    if interrupted:
        note += f"\n\nInterrupted by {interrupted} after {len(results)} runs: the table is partial."
    if failures:
        note += "\n\nRuns that did not complete (left out of the table):\n" + "\n".join(failures)
    (args.out / "table.md").write_text(text + "\n\n" + note + "\n")
    scoring.write_json([asdict(r) for r in results], args.out / "results.json")
    print(f"\n{text}\n\n{note}")
    if interrupted:
        return stop_signals.INTERRUPTED_EXIT_CODE
    return 1 if failures else 0


def _isolate_ros(domain_id: int | None) -> None:
    """The graph runs' nodes and recorder use this process's environment (see module doc)."""
    if domain_id is None:
        taken = os.environ.get("ROS_DOMAIN_ID", "0")
        domain_id = private_domain_id(os.getpid(), int(taken) if taken.isdigit() else 0)
    os.environ["ROS_DOMAIN_ID"] = str(domain_id)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    print(f"graph runs on ROS_DOMAIN_ID {domain_id}, localhost only", flush=True)


def _scenes_of(
    name: str, args: argparse.Namespace, background: np.ndarray | None, people: RealPeople
) -> Iterator[tuple[str, int, Path, Replay]]:
    """(label, seed, scene directory, replay) of each scene of `name`: the clip once; a preset's
    seeds (--first-seed, --seeds), rendered when not cached."""
    chosen = SCENES[name]
    if isinstance(chosen, AnnotatedClip):
        scene_dir, replay = prepare_clip(chosen, args.out / "scenes")
        yield name, 0, scene_dir, replay
        return
    small = isinstance(chosen, small_objects.SmallObjectsConfig)
    for k in range(args.first_seed, args.first_seed + args.seeds):
        config = replace(chosen, seed=chosen.seed + k, num_frames=args.frames or chosen.num_frames)
        ground = None if small else background
        scene_dir = prepare_scene(name, config, ground, args.out / "scenes", people)
        yield f"{name}-{config.seed}", config.seed, scene_dir, load_scene(scene_dir)


def _run_all(
    args: argparse.Namespace,
    scene_names: list[str],
    runs: dict[str, list[str]],
    background: np.ndarray | None,
    extra: dict[str, dict[str, Any]],
    results: list[RunScores],
    failures: list[str],
) -> None:
    """Every scene x configuration x path, appending to `results` and `failures` as they end."""
    people = RealPeople()
    for name in scene_names:
        if not runs[name]:
            continue
        small = scene_kind(SCENES[name]) == SMALL_OBJECTS
        graph = args.graph is not None and (not args.graph or name in args.graph)
        paths = PATHS if graph else PATHS[:1]
        for label, seed, scene_dir, scene in _scenes_of(name, args, background, people):
            for configuration in runs[name]:
                for path in paths:
                    print(f"{label} / {configuration} / {path} ...", flush=True)
                    chosen = CONFIGURATIONS[configuration]
                    overrides = _merged(chosen.overrides, extra)
                    try:
                        result = benchmark_one(
                            label,
                            scene_dir,
                            scene,
                            configuration,
                            chosen.graph,
                            overrides,
                            path,
                            args.out,
                            centres=small,
                        )
                    except RuntimeError as error:  # an incomplete graph run: say so, go on
                        failures.append(f"{label} / {configuration} / {path}: {error}")
                        print(f"FAILED: {failures[-1]}", file=sys.stderr, flush=True)
                        continue
                    results.append(replace(result, scene=name, seed=seed))
                    print(scoring.format_scores(result.scores), flush=True)


if __name__ == "__main__":
    raise SystemExit(main())
