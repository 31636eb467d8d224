"""The surveillance graph in one process, for fast benchmarks (no rclpy).

Per scene frame, in the order the lockstep graph runs it: the camera model advances to the frame's
stamp and renders its window (ptz_camera), the registered detector finds blobs in that image
(detector), the registered tracker steps with them and the target selector picks the track to
follow (tracker), and the pan-tilt controller answers with a command the camera applies before the
next frame (ptz_controller). Parameters come from the same params file the graph uses
(config/surveillance.yaml) on top of each method's defaults, with the same `node.param` overrides.

What it leaves out is transport: the messages' conversions are mirrored (blob areas are rounded as
tracker_msgs/Blob stores them; the mask reaches the tracker as mono8 0/255), so a run matches the
graph's run on the same input up to DDS timing, which lockstep removes.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tracker_detect.detector import CameraFrame, Detection, Detector
from tracker_detect.detectors import DETECTORS
from tracker_detect.registration import View
from tracker_filter.config import SELECTION_DEFAULTS
from tracker_filter.models import extrapolate_positions
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.selection import AUTOMATIC_POLICIES, TargetSelector
from tracker_filter.trackers import TRACKERS
from tracker_filter.tracking import Tracker, TrackSet
from tracker_msgs_py.codec import NS_PER_S
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.params import config_from_params
from tracker_ptz_sim.bringup.graph import node_parameters
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

CAMERA, DETECTOR, TRACKER, CONTROLLER = "ptz_camera", "ssim_detector", "tracker", "ptz_controller"
Overrides = Mapping[str, Mapping[str, Any]]  # node name -> parameter -> value


@dataclass(frozen=True)
class PipelineSettings:
    """Everything the graph's nodes are configured with, resolved to plain values."""

    camera: PtzConfig
    detector_method: str
    detector_values: dict[str, Any]
    tracker_method: str
    tracker_values: dict[str, Any]
    selection: dict[str, Any]  # the tracker's selection parameters (config.SELECTION_PARAMETERS)
    controller: ControllerConfig

    @classmethod
    def from_params_files(
        cls, params_files: Sequence[Path], overrides: Overrides | None = None
    ) -> PipelineSettings:
        """The settings params files (and `node -> param -> value` overrides) give the graph."""
        overrides = overrides or {}

        def params(node: str) -> dict[str, Any]:
            return {**node_parameters(params_files, node), **overrides.get(node, {})}

        camera, detector, tracker, control = (
            params(n) for n in (CAMERA, DETECTOR, TRACKER, CONTROLLER)
        )
        detector_method = DETECTORS.get(detector.get("method", DETECTORS.names()[0]))
        tracker_method = TRACKERS.get(tracker.get("method", TRACKERS.names()[0]))
        preset = tracker.get("preset") or ("multi" if "multi" in tracker_method.presets else "")
        tracker_all = {**SELECTION_DEFAULTS, **tracker_method.defaults(preset), **tracker}
        controller_defaults = ControllerConfig()
        control_values = {
            **{k: getattr(controller_defaults, k) for k in ControllerConfig.__dataclass_fields__},
            "pan_limits": list(controller_defaults.pan_limits),
            "home": list(controller_defaults.home),
            "presets": [v for pose in controller_defaults.presets for v in pose],
            **control,
        }
        return cls(
            camera=config_from_params(PtzConfig, camera),
            detector_method=detector_method.name,
            detector_values=_method_values(detector_method.defaults(), detector),
            tracker_method=tracker_method.name,
            tracker_values=_method_values(tracker_method.defaults(preset), tracker_all),
            selection={name: tracker_all[name] for name in SELECTION_DEFAULTS},
            controller=controller_config(control_values),
        )


def _method_values(defaults: Mapping[str, Any], given: Mapping[str, Any]) -> dict[str, Any]:
    """The method's parameters: its defaults, replaced by the values given for them."""
    return {name: given.get(name, value) for name, value in defaults.items()}


@dataclass
class Step:
    """What the graph produced for one scene frame."""

    stamp_ns: int
    camera: PtzSnapshot  # the pose the frame's image was taken at
    view: np.ndarray  # the camera image
    detection: Detection
    tracks: TrackSet
    target_id: int | None  # the locked track, None when nothing is followed
    target: TargetEstimate | None
    command: Command


@dataclass
class InProcessGraph:
    """The graph's nodes as plain objects; `step` once per scene frame, in stamp order."""

    settings: PipelineSettings
    scene_width: int
    scene_height: int
    camera: PtzCameraModel = field(init=False)
    detector: Detector = field(init=False)
    tracker: Tracker = field(init=False)
    selector: TargetSelector = field(init=False)
    controller: PanTiltController = field(init=False)
    _epoch_ns: int | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        s = self.settings
        self.camera = PtzCameraModel(s.camera, self.scene_width, self.scene_height)
        self.detector = DETECTORS.get(s.detector_method).build(s.detector_values)
        self.tracker = TRACKERS.get(s.tracker_method).build(s.tracker_values, 1)
        self.selector = TargetSelector(
            AUTOMATIC_POLICIES[s.selection["selection_policy"]],
            s.selection["min_lock_time"],
            s.selection["switch_margin"],
            s.selection["target_max_misses"],
        )
        self.controller = PanTiltController(s.controller)

    def step(self, stamp_ns: int, scene: np.ndarray) -> Step:
        t = stamp_ns / NS_PER_S
        snapshot = self.camera.advance(t)
        view = self.camera.render(scene, snapshot.window)
        height, width = view.shape[:2]
        detection = self.detector.process(
            CameraFrame(stamp_ns, view, View(snapshot.window, width, height))
        )
        tracks = self._track(stamp_ns, view, detection, snapshot.window)
        selection = self.selector.update(tracks, snapshot.window.center)
        target_id = selection.track_id if selection is not None else None
        target = self._target(tracks, target_id)
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
        locked = target_id if target is not None else None
        return Step(stamp_ns, snapshot, view, detection, tracks, locked, target, command)

    def _track(
        self, stamp_ns: int, view: np.ndarray, detection: Detection, window: Rect
    ) -> TrackSet:
        if self._epoch_ns is None:
            self._epoch_ns = stamp_ns
        needs = self.tracker.needs
        mask = detection.mask * np.uint8(255) if detection.mask is not None else None
        return self.tracker.step(
            Observation(
                time=(stamp_ns - self._epoch_ns) / NS_PER_S,
                detections=detections_of(detection),
                present=detection.target_present,
                image=view if Need.IMAGE in needs else None,
                mask=mask if Need.MASK in needs else None,
                window=window if Need.WINDOW in needs else None,
            )
        )

    def _target(self, tracks: TrackSet, track_id: int | None) -> TargetEstimate | None:
        """The controller's view of the locked track, as the Target message carries it."""
        index = None if track_id is None else tracks.index_of(track_id)
        if index is None:
            return None
        mean, layout = tracks.means[index], tracks.layout
        x, y = (float(v) for v in layout.positions(mean))
        vx, vy = (float(v) for v in layout.velocities(mean))
        lead = float(self.settings.selection["lead_time"])
        px, py = (float(v) for v in extrapolate_positions(mean, layout, lead)[0])
        values = (x, y, vx, vy, px, py)
        height = float(tracks.bboxes[index][3])
        return TargetEstimate(*values, height=height) if all(np.isfinite(values)) else None


def detections_of(detection: Detection) -> Detections:
    """The detector's blobs as the tracker receives them (tracker_msgs/BlobArray: integer areas,
    nothing when the presence test failed)."""
    if not detection.target_present or not detection.blobs:
        return Detections.empty()
    blobs = detection.blobs
    return Detections(
        positions=np.array([(b.centroid_x, b.centroid_y) for b in blobs], dtype=float),
        areas=np.array([round(b.area) for b in blobs], dtype=float),
        bboxes=np.array([(b.bbox.x, b.bbox.y, b.bbox.width, b.bbox.height) for b in blobs]),
        scores=np.array([b.score for b in blobs], dtype=float),
    )


def run(
    frames: Iterable[np.ndarray], stamps_ns: Iterable[int], settings: PipelineSettings
) -> Iterator[Step]:
    """Step a fresh graph through the scene frames (BGR, all the same size) at their stamps."""
    graph: InProcessGraph | None = None
    for frame, stamp in zip(frames, stamps_ns, strict=True):
        if graph is None:
            graph = InProcessGraph(settings, frame.shape[1], frame.shape[0])
        yield graph.step(stamp, frame)
