"""A graph in one process, for fast benchmarks (no rclpy).

Per scene frame, in the order the lockstep graph runs it: the camera model advances to the frame's
stamp and renders its window (ptz_camera), the registered detector finds blobs in that image
(ssim_detector; `detector` in the small-objects graph), the registered tracker steps with them and
the target selector picks the track to follow (tracker), and the pan-tilt controller answers with a
command the camera applies before the next frame (ptz_controller). In the colour graph the motion
tracker's target is then offered to the seeded detector (colour_detector, through
`tracker_detect.seeding`, guided by its own tracker's previous target) and its tracker
(colour_tracker) picks what the controller follows. Parameters come from the same params files the
graph uses on top of each method's defaults, with the same `node.param` overrides.

What it leaves out is transport: the messages' conversions are mirrored (blob areas are rounded as
tracker_msgs/Blob stores them; the mask reaches the tracker as mono8 0/255; targets carry the
locked track's box, hits, position and velocity), so a run matches the graph's run on the same
input up to DDS timing, which lockstep removes.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tracker_detect.detector import CameraFrame, Detection, Detector, SeededDetector
from tracker_detect.detectors import DETECTORS
from tracker_detect.registration import View
from tracker_detect.seeding import (
    SEEDING_PARAMETERS,
    Guidance,
    Offer,
    SeededSession,
    SeedingConfig,
    initial_region,
)
from tracker_filter.models import extrapolate_positions
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.selection import SELECTION_DEFAULTS, SelectionConfig
from tracker_filter.trackers import TRACKERS
from tracker_filter.tracking import Tracker, TrackSet, TrackStatus
from tracker_msgs_py.codec import NS_PER_S
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.params import config_from_params
from tracker_ptz_sim.bringup.graph import Graph, node_parameters
from tracker_ptz_sim.control.controller import (
    CameraPose,
    Command,
    ControllerConfig,
    PanTiltController,
    TargetEstimate,
    controller_config,
)
from tracker_ptz_sim.simulation.camera_model import (
    PtzCameraModel,
    PtzCommand,
    PtzConfig,
    PtzSnapshot,
)

CAMERA, CONTROLLER = "ptz_camera", "ptz_controller"
DETECTOR, TRACKER = "ssim_detector", "tracker"
COLOUR_DETECTOR, COLOUR_TRACKER = "colour_detector", "colour_tracker"
Overrides = Mapping[str, Mapping[str, Any]]  # node name -> parameter -> value


@dataclass(frozen=True)
class StageSettings:
    """One detector node and the tracker node fed by it, resolved to plain values."""

    detector_method: str
    detector_values: dict[str, Any]
    tracker_method: str
    tracker_values: dict[str, Any]
    selection: dict[str, Any]  # the tracker's selection parameters (selection.SelectionConfig)
    seeding: SeedingConfig | None = None  # a seeded detector's hand-over policy and guidance
    initial_region: Rect | None = None

    @classmethod
    def of(cls, detector: dict[str, Any], tracker: dict[str, Any]) -> StageSettings:
        """From the two nodes' parameters (each method's defaults for what they do not set)."""
        detector_method = DETECTORS.get(detector.get("method", DETECTORS.names()[0]))
        tracker_method = TRACKERS.get(tracker.get("method", TRACKERS.names()[0]))
        preset = tracker.get("preset") or ("multi" if "multi" in tracker_method.presets else "")
        tracker_all = {**SELECTION_DEFAULTS, **tracker_method.defaults(preset), **tracker}
        seeding, initial = None, None
        node = {spec.name: spec.default for spec in SEEDING_PARAMETERS} | detector
        detector_values = _method_values(detector_method.defaults(), detector)
        if isinstance(detector_method.build(detector_values), SeededDetector):
            seeding = config_from_params(SeedingConfig, node)
            initial = initial_region(node["initial_region"])
        return cls(
            detector_method.name,
            detector_values,
            tracker_method.name,
            _method_values(tracker_method.defaults(preset), tracker_all),
            {name: tracker_all[name] for name in SELECTION_DEFAULTS},
            seeding,
            initial,
        )


@dataclass(frozen=True)
class PipelineSettings:
    """Everything the graph's nodes are configured with, resolved to plain values."""

    camera: PtzConfig
    motion: StageSettings  # ssim_detector + tracker
    controller: ControllerConfig
    colour: StageSettings | None = None  # colour_detector + colour_tracker (the colour graph)

    @property
    def followed_labels(self) -> tuple[str, ...]:
        """The labels of the tracks the camera follows (the followed tracker's track_labels)."""
        stage = self.colour or self.motion
        return tuple(stage.selection["track_labels"])

    @classmethod
    def from_graph(cls, graph: Graph, overrides: Overrides | None = None) -> PipelineSettings:
        """The settings of `graph`'s nodes (its params files and `node -> param -> value`
        overrides)."""
        overrides = overrides or {}

        def params(node: str) -> dict[str, Any]:
            return {**node_parameters(graph.params_files, node), **overrides.get(node, {})}

        controller_defaults = ControllerConfig()
        control_values = {
            **{k: getattr(controller_defaults, k) for k in ControllerConfig.__dataclass_fields__},
            "pan_limits": list(controller_defaults.pan_limits),
            "home": list(controller_defaults.home),
            "presets": [v for pose in controller_defaults.presets for v in pose],
            **params(CONTROLLER),
        }
        names = {node.name for node in graph.nodes}
        colour = None
        if COLOUR_DETECTOR in names:
            colour = StageSettings.of(params(COLOUR_DETECTOR), params(COLOUR_TRACKER))
        return cls(
            camera=config_from_params(PtzConfig, params(CAMERA)),
            motion=StageSettings.of(params(detector_node(graph)), params(TRACKER)),
            controller=controller_config(control_values),
            colour=colour,
        )


def detector_node(graph: Graph) -> str:
    """The name of the detector node feeding `tracker`: the graph's detector executable that is not
    the colour graph's `colour_detector` (`ssim_detector` in the surveillance graphs)."""
    names = [
        n.name for n in graph.nodes if n.executable == "detector" and n.name != COLOUR_DETECTOR
    ]
    return names[0] if names else DETECTOR


def _method_values(defaults: Mapping[str, Any], given: Mapping[str, Any]) -> dict[str, Any]:
    """The method's parameters: its defaults, replaced by the values given for them."""
    return {name: given.get(name, value) for name, value in defaults.items()}


@dataclass
class Step:
    """What the graph produced for one scene frame: the followed pipeline's detection, tracks and
    target (the colour one in the colour graph, as the recorded topics hold them)."""

    stamp_ns: int
    camera: PtzSnapshot  # the pose the frame's image was taken at
    view: np.ndarray  # the camera image
    detection: Detection
    tracks: TrackSet
    target_id: int | None  # the locked track, None when nothing is followed
    target: TargetEstimate | None
    command: Command


@dataclass
class Tracked:
    """A tracker node's output for one frame: its tracks and its target."""

    tracks: TrackSet
    target_id: int | None  # the selected track, None when nothing is selected
    index: int | None  # the selected track's row in `tracks`

    @property
    def locked(self) -> bool:
        return self.index is not None


class TrackingStage:
    """A tracker node: the registered tracker, target selection, and its time base."""

    def __init__(self, settings: StageSettings) -> None:
        self.tracker: Tracker = TRACKERS.get(settings.tracker_method).build(
            settings.tracker_values, 1
        )
        selection = config_from_params(SelectionConfig, settings.selection)
        self.selector = selection.selector()
        self.lead_time = selection.lead_time
        self._epoch_ns: int | None = None

    def step(self, stamp_ns: int, view: np.ndarray, detection: Detection, window: Rect) -> Tracked:
        if self._epoch_ns is None:
            self._epoch_ns = stamp_ns
        needs = self.tracker.needs
        mask = detection.mask * np.uint8(255) if detection.mask is not None else None
        tracks = self.tracker.step(
            Observation(
                time=(stamp_ns - self._epoch_ns) / NS_PER_S,
                detections=detections_of(detection),
                present=detection.target_present,
                image=view if Need.IMAGE in needs else None,
                mask=mask if Need.MASK in needs else None,
                window=window if Need.WINDOW in needs else None,
            )
        )
        selection = self.selector.update(tracks, window.center)
        track_id = selection.track_id if selection is not None else None
        index = None if track_id is None else tracks.index_of(track_id)
        return Tracked(tracks, track_id, index)

    def target(self, tracked: Tracked) -> TargetEstimate | None:
        """The controller's view of the locked track, as the Target message carries it."""
        if tracked.index is None:
            return None
        tracks = tracked.tracks
        mean, layout = tracks.means[tracked.index], tracks.layout
        x, y = (float(v) for v in layout.positions(mean))
        vx, vy = (float(v) for v in layout.velocities(mean))
        px, py = (float(v) for v in extrapolate_positions(mean, layout, self.lead_time)[0])
        values = (x, y, vx, vy, px, py)
        height = float(tracks.bboxes[tracked.index][3])
        return TargetEstimate(*values, height=height) if all(np.isfinite(values)) else None


def offer_of(stamp_ns: int, tracked: Tracked) -> Offer | None:
    """A tracker's target as the hand-over source sees it (tracker_msgs/Target's track)."""
    if tracked.index is None:
        return None
    tracks, i = tracked.tracks, tracked.index
    box = Rect(*(float(v) for v in tracks.bboxes[i]))
    box = Rect(box.x, box.y, max(box.width, 0.0), max(box.height, 0.0))
    measured = int(tracks.status[i]) == int(TrackStatus.CONFIRMED)
    return Offer(stamp_ns, int(tracks.ids[i]), box, measured, int(tracks.hits[i]))


def guidance_of(stamp_ns: int, tracked: Tracked) -> Guidance | None:
    """A tracker's target as its seeded detector's guidance (locked and not lost)."""
    if tracked.index is None or int(tracked.tracks.status[tracked.index]) == int(TrackStatus.LOST):
        return None
    tracks, i = tracked.tracks, tracked.index
    x, y = (float(v) for v in tracks.layout.positions(tracks.means[i]))
    vx, vy = (float(v) for v in tracks.layout.velocities(tracks.means[i]))
    return Guidance(stamp_ns, x, y, vx, vy)


class ColourStage:
    """The colour graph's colour_detector (a seeded detector) and colour_tracker."""

    def __init__(self, settings: StageSettings) -> None:
        detector = DETECTORS.get(settings.detector_method).build(settings.detector_values)
        if not isinstance(detector, SeededDetector):
            raise ValueError(f"{settings.detector_method} is not a seeded detector")
        self.session = SeededSession(detector, settings.seeding, settings.initial_region)
        self.tracking = TrackingStage(settings)
        self.guide: Guidance | None = None

    def step(
        self, frame: CameraFrame, window: Rect, offer: Offer | None
    ) -> tuple[Detection, Tracked]:
        seeded = self.session.step(frame, offer, self.guide)
        if seeded.offer is not None and seeded.offer.taken:
            self.guide = None
        tracked = self.tracking.step(frame.stamp_ns, frame.image, seeded.detection, window)
        self.guide = guidance_of(frame.stamp_ns, tracked)
        return seeded.detection, tracked


@dataclass
class InProcessGraph:
    """The graph's nodes as plain objects; `step` once per scene frame, in stamp order."""

    settings: PipelineSettings
    scene_width: int
    scene_height: int
    camera: PtzCameraModel = field(init=False)
    detector: Detector = field(init=False)
    motion: TrackingStage = field(init=False)
    colour: ColourStage | None = field(init=False)
    controller: PanTiltController = field(init=False)

    def __post_init__(self) -> None:
        s = self.settings
        self.camera = PtzCameraModel(s.camera, self.scene_width, self.scene_height)
        self.detector = DETECTORS.get(s.motion.detector_method).build(s.motion.detector_values)
        self.motion = TrackingStage(s.motion)
        self.colour = ColourStage(s.colour) if s.colour is not None else None
        self.controller = PanTiltController(s.controller)

    def step(self, stamp_ns: int, scene: np.ndarray) -> Step:
        t = stamp_ns / NS_PER_S
        snapshot = self.camera.advance(t)
        view = self.camera.render(scene, snapshot.window)
        height, width = view.shape[:2]
        frame = CameraFrame(stamp_ns, view, View(snapshot.window, width, height))
        detection = self.detector.process(frame)
        tracked = self.motion.step(stamp_ns, view, detection, snapshot.window)
        followed = self.motion
        if self.colour is not None:
            offer = offer_of(stamp_ns, tracked)
            detection, tracked = self.colour.step(frame, snapshot.window, offer)
            followed = self.colour.tracking
        target = followed.target(tracked)
        pose = CameraPose(
            snapshot.pan,
            snapshot.tilt,
            *snapshot.window.center,
            self.camera.geometry.focal_length,
            snapshot.zoom,
            snapshot.window.height,
        )
        command = self.controller.step(t, pose, target)
        self.camera.command(
            PtzCommand(
                t,
                command.mode.value,
                command.pan,
                command.tilt,
                command.pan_rate,
                command.tilt_rate,
                command.zoom,
            )
        )
        locked = tracked.target_id if target is not None else None
        return Step(stamp_ns, snapshot, view, detection, tracked.tracks, locked, target, command)


def detections_of(detection: Detection) -> Detections:
    """The detector's blobs as the tracker receives them (tracker_msgs/BlobArray)."""
    return Detections.from_blobs(detection.blobs, detection.target_present)


def run(
    frames: Iterable[np.ndarray], stamps_ns: Iterable[int], settings: PipelineSettings
) -> Iterator[Step]:
    """Step a fresh graph through the scene frames (BGR, all the same size) at their stamps."""
    graph: InProcessGraph | None = None
    for frame, stamp in zip(frames, stamps_ns, strict=True):
        if graph is None:
            graph = InProcessGraph(settings, frame.shape[1], frame.shape[0])
        yield graph.step(stamp, frame)
