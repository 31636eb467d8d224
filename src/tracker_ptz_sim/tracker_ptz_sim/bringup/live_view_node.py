"""live_view: the running graph in the Foxglove app, over a foxglove-sdk WebSocket server (thin
shell over evaluation/live_view.py).

Subscribes `camera/image_raw`, `scene/image_raw` (sensor_msgs/Image), `ptz/state`
(tracker_msgs/PtzState), `detections` (BlobArray), `tracks` (TrackArray) and `target` (Target);
serves /camera/image, /camera/annotations, /scene/image, /scene/annotations and /ptz/state on
ws://`host`:`port` (open it in Foxglove: "Open connection" → Foxglove WebSocket). Each frame's boxes
go out when its target arrives (the last result of a frame), drawn over that frame's camera window.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from sensor_msgs.msg import Image

from tracker_msgs.msg import BlobArray, PtzState, Target, Track, TrackArray
from tracker_msgs_py.codec import (
    UnsupportedEncodingError,
    image_qos,
    image_to_bgr,
    msg_to_rect,
    msg_to_window,
    result_qos,
    stamp_to_ns,
)
from tracker_msgs_py.node_main import StartupError, SuiteNode, run_node
from tracker_msgs_py.params import config_from_params, declare_parameters, param, specs_of
from tracker_ptz_sim.evaluation.live_view import Box, LiveView, ViewSettings

FRAMES_KEPT = 32  # per-stamp results kept until their frame's target arrives


@dataclass(frozen=True)
class LiveViewConfig:
    """The live view node's parameters."""

    host: str = param("127.0.0.1", "address to serve on (0.0.0.0: every interface)", read_only=True)
    port: int = param(8765, "WebSocket port (0: any free port)", min=0, max=65535, read_only=True)
    jpeg_quality: int = param(80, "JPEG quality of the images sent", min=10, max=100)
    scene_width: int = param(
        640, "width the scene image is scaled to (0: its own)", min=0, max=10000, unit="px"
    )
    reliable_images: bool = param(
        False, "reliable QoS for images (lockstep replays)", read_only=True
    )

    def problems(self) -> list[str]:
        return []


PARAMS = specs_of(LiveViewConfig)


class LiveViewNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("live_view", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change)
        self.settings = config_from_params(LiveViewConfig, self.params)
        try:
            self.view = LiveView(self._view_settings(), name=self.get_fully_qualified_name())
        except Exception as error:  # the port is taken, the address is not ours...
            raise StartupError(
                f"cannot serve on {self.settings.host}:{self.settings.port}: {error}"
            ) from error
        self.windows: OrderedDict[int, Any] = OrderedDict()
        self.detections: OrderedDict[int, list[Box]] = OrderedDict()
        self.tracks: OrderedDict[int, list[Box]] = OrderedDict()
        self.camera_size: tuple[int, int] | None = None
        self.scene_size: tuple[int, int] | None = None
        qos = image_qos(self.settings.reliable_images)
        self.create_subscription(Image, "camera/image_raw", self._on_camera, qos)
        self.create_subscription(Image, "scene/image_raw", self._on_scene, qos)
        results = result_qos(late_joiners=False)  # what is happening now, not the history
        self.create_subscription(PtzState, "ptz/state", self._on_state, results)
        self.create_subscription(BlobArray, "detections", self._on_detections, results)
        self.create_subscription(TrackArray, "tracks", self._on_tracks, results)
        self.create_subscription(Target, "target", self._on_target, results)
        self.get_logger().info(
            f"live view on ws://{self.settings.host}:{self.view.port} (Foxglove: Open connection "
            "-> Foxglove WebSocket)"
        )

    def _view_settings(self) -> ViewSettings:
        s = self.settings
        return ViewSettings(s.host, s.port, s.jpeg_quality, s.scene_width)

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(LiveViewConfig, self.params)
        self.view.settings = self._view_settings()

    def destroy_node(self) -> None:
        self.view.close()
        super().destroy_node()

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        return "serving", {"url": f"ws://{self.settings.host}:{self.view.port}"}

    # --- inputs -------------------------------------------------------------------------------

    def _image(self, msg: Image) -> Any:
        try:
            return image_to_bgr(msg)
        except UnsupportedEncodingError as error:
            self.problems.report(error.cause, f"not shown: {error}")
            return None

    def _on_camera(self, msg: Image) -> None:
        pixels = self._image(msg)
        if pixels is not None:
            self.camera_size = (pixels.shape[1], pixels.shape[0])
            stamp = stamp_to_ns(msg.header.stamp)
            self.view.log_camera(stamp, msg.header.frame_id, pixels)

    def _on_scene(self, msg: Image) -> None:
        pixels = self._image(msg)
        if pixels is not None:
            self.scene_size = (pixels.shape[1], pixels.shape[0])
            self.view.log_scene(stamp_to_ns(msg.header.stamp), msg.header.frame_id, pixels)

    def _on_state(self, msg: PtzState) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        try:
            _keep(self.windows, stamp, msg_to_window(msg.window))
        except ValueError as error:
            self.problems.report("invalid PtzState window", f"not shown: {error}")
        self.view.log_ptz_state(
            stamp,
            {
                "pan": msg.pan,
                "tilt": msg.tilt,
                "pan_rate": msg.pan_rate,
                "tilt_rate": msg.tilt_rate,
                "zoom": msg.zoom,
                "window": {
                    "x": msg.window.x,
                    "y": msg.window.y,
                    "width": msg.window.width,
                    "height": msg.window.height,
                },
                "moving": msg.moving,
            },
        )

    def _on_detections(self, msg: BlobArray) -> None:
        boxes = [Box(msg_to_rect(b.bbox), "", "detection") for b in msg.blobs]
        _keep(self.detections, stamp_to_ns(msg.header.stamp), boxes)

    def _on_tracks(self, msg: TrackArray) -> None:
        boxes = [
            Box(msg_to_rect(t.bbox), str(t.id), _kind(t))
            for t in msg.tracks
            if t.status in (Track.STATUS_CONFIRMED, Track.STATUS_COASTING)
        ]
        _keep(self.tracks, stamp_to_ns(msg.header.stamp), boxes)

    def _on_target(self, msg: Target) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        boxes = self.detections.pop(stamp, []) + self.tracks.pop(stamp, [])
        if msg.locked:
            boxes.append(Box(msg_to_rect(msg.track.bbox), f"target {msg.track.id}", "target"))
        window = self.windows.get(stamp)
        self.view.log_boxes(stamp, boxes, window, self.camera_size, self.scene_size)


def _kind(track: Track) -> str:
    return "track" if track.status == Track.STATUS_CONFIRMED else "coasting"


def _keep(by_stamp: OrderedDict[int, Any], stamp: int, value: Any) -> None:
    by_stamp[stamp] = value
    while len(by_stamp) > FRAMES_KEPT:
        by_stamp.popitem(last=False)


def main(args: list[str] | None = None) -> int:
    return run_node(LiveViewNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
