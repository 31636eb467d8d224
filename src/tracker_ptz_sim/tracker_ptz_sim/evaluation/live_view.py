"""The graph as the Foxglove app shows it (no rclpy): images as JPEG CompressedImages, boxes as
ImageAnnotations, the pan-tilt state as JSON, on channels of a foxglove-sdk WebSocket server.

`LiveView` owns the channels (in its own foxglove Context, so two views never share one) and
turns the suite's data into Foxglove's schemas:

    /camera/image        foxglove.CompressedImage   the camera view
    /camera/annotations  foxglove.ImageAnnotations  detections (grey), tracks (green when observed,
                                                    dashed-looking thin outline when coasting),
                                                    the target (orange), in camera pixels
    /scene/image         foxglove.CompressedImage   the replayed scene, scaled to `scene_width`
    /scene/annotations   foxglove.ImageAnnotations  the camera window (cyan), tracks, target
    /ptz/state           JSON                       pan, tilt, rates, zoom, window, moving

Boxes arrive in scene pixels; the camera's are mapped through the window of the same stamp.
In the Foxglove app: an Image panel on /camera/image with /camera/annotations enabled, another on
/scene/image with /scene/annotations, a Plot panel of /ptz/state.pan and .tilt.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import foxglove
import numpy as np
from foxglove.channels import CompressedImageChannel, ImageAnnotationsChannel
from foxglove.messages import (
    Color,
    CompressedImage,
    ImageAnnotations,
    Point2,
    PointsAnnotation,
    PointsAnnotationType,
    TextAnnotation,
    Timestamp,
)

from tracker_msgs_py.geometry import Rect

DETECTION = Color(r=0.8, g=0.8, b=0.8, a=1.0)
OBSERVED = Color(r=0.2, g=0.9, b=0.3, a=1.0)
COASTING = Color(r=0.2, g=0.9, b=0.3, a=0.5)
TARGET = Color(r=1.0, g=0.55, b=0.0, a=1.0)
WINDOW = Color(r=0.0, g=0.85, b=1.0, a=1.0)


@dataclass(frozen=True)
class Box:
    """A box to draw, in scene pixels."""

    rect: Rect
    label: str = ""
    kind: str = "track"  # "detection", "track", "coasting", "target"


@dataclass(frozen=True)
class ViewSettings:
    host: str = "127.0.0.1"
    port: int = 8765  # 0: any free port (`LiveView.port` says which)
    jpeg_quality: int = 80
    scene_width: int = 640  # px the scene image is scaled to (0: its own size)


class LiveView:
    """A foxglove WebSocket server with the channels of the module docstring."""

    def __init__(self, settings: ViewSettings, name: str = "tracker suite") -> None:
        self.settings = settings
        self.context = foxglove.Context()
        self.server = foxglove.start_server(
            name=name, host=settings.host, port=settings.port, context=self.context
        )
        self.camera_image = CompressedImageChannel("/camera/image", context=self.context)
        self.camera_annotations = ImageAnnotationsChannel(
            "/camera/annotations", context=self.context
        )
        self.scene_image = CompressedImageChannel("/scene/image", context=self.context)
        self.scene_annotations = ImageAnnotationsChannel("/scene/annotations", context=self.context)
        self.ptz_state = foxglove.Channel(
            "/ptz/state", message_encoding="json", context=self.context
        )

    @property
    def port(self) -> int:
        return int(self.server.port)

    def close(self) -> None:
        self.server.stop()

    def log_camera(self, stamp_ns: int, frame_id: str, image: np.ndarray) -> None:
        self.camera_image.log(self._jpeg(stamp_ns, frame_id, image), log_time=stamp_ns)

    def log_scene(self, stamp_ns: int, frame_id: str, image: np.ndarray) -> None:
        self.scene_image.log(self._jpeg(stamp_ns, frame_id, self._scaled(image)), log_time=stamp_ns)

    def log_boxes(
        self,
        stamp_ns: int,
        boxes: list[Box],
        window: Rect | None,
        camera_size: tuple[int, int] | None,
        scene_size: tuple[int, int] | None,
    ) -> None:
        """The boxes over the camera view (when its window and size are known) and over the
        scene image (with the window, when the scene's size is known)."""
        stamp = _timestamp(stamp_ns)
        if window is not None and camera_size is not None:
            width, height = camera_size
            sx, sy = width / window.width, height / window.height
            in_camera = [
                _polygon(
                    box,
                    Rect(
                        (box.rect.x - window.x) * sx,
                        (box.rect.y - window.y) * sy,
                        box.rect.width * sx,
                        box.rect.height * sy,
                    ),
                    stamp,
                )
                for box in boxes
            ]
            self.camera_annotations.log(_annotations(in_camera), log_time=stamp_ns)
        if scene_size is not None:
            scale = self._scene_scale(scene_size[0])
            shown = list(boxes)
            if window is not None:
                shown.append(Box(window, "camera", "window"))
            in_scene = [_polygon(box, _scaled_rect(box.rect, scale), stamp) for box in shown]
            self.scene_annotations.log(_annotations(in_scene), log_time=stamp_ns)

    def log_ptz_state(self, stamp_ns: int, state: dict[str, object]) -> None:
        self.ptz_state.log(state, log_time=stamp_ns)

    def _jpeg(self, stamp_ns: int, frame_id: str, image: np.ndarray) -> CompressedImage:
        quality = [cv2.IMWRITE_JPEG_QUALITY, self.settings.jpeg_quality]
        ok, encoded = cv2.imencode(".jpg", image, quality)
        if not ok:
            raise ValueError(f"could not encode a {image.shape} image as JPEG")
        return CompressedImage(
            timestamp=_timestamp(stamp_ns), frame_id=frame_id, data=encoded.tobytes(), format="jpeg"
        )

    def _scene_scale(self, width: int) -> float:
        wanted = self.settings.scene_width
        return 1.0 if wanted <= 0 or width <= wanted else wanted / width

    def _scaled(self, image: np.ndarray) -> np.ndarray:
        scale = self._scene_scale(image.shape[1])
        if scale == 1.0:
            return image
        size = (round(image.shape[1] * scale), round(image.shape[0] * scale))
        return cv2.resize(image, size, interpolation=cv2.INTER_AREA)


def _timestamp(stamp_ns: int) -> Timestamp:
    return Timestamp(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)


def _scaled_rect(rect: Rect, scale: float) -> Rect:
    return Rect(rect.x * scale, rect.y * scale, rect.width * scale, rect.height * scale)


COLOURS = {
    "detection": DETECTION,
    "track": OBSERVED,
    "coasting": COASTING,
    "target": TARGET,
    "window": WINDOW,
}


def _polygon(
    box: Box, rect: Rect, stamp: Timestamp
) -> tuple[PointsAnnotation, TextAnnotation | None]:
    colour = COLOURS[box.kind]
    corners = [
        Point2(x=rect.x, y=rect.y),
        Point2(x=rect.x + rect.width, y=rect.y),
        Point2(x=rect.x + rect.width, y=rect.y + rect.height),
        Point2(x=rect.x, y=rect.y + rect.height),
    ]
    outline = PointsAnnotation(
        timestamp=stamp,
        type=PointsAnnotationType.LineLoop,
        points=corners,
        outline_color=colour,
        thickness=1.0 if box.kind in ("detection", "coasting") else 2.0,
    )
    label = (
        TextAnnotation(
            timestamp=stamp,
            position=Point2(x=rect.x, y=max(0.0, rect.y - 4.0)),
            text=box.label,
            font_size=12.0,
            text_color=colour,
        )
        if box.label
        else None
    )
    return outline, label


def _annotations(shapes: list[tuple[PointsAnnotation, TextAnnotation | None]]) -> ImageAnnotations:
    points = [outline for outline, _ in shapes]
    texts = [label for _, label in shapes if label is not None]
    return ImageAnnotations(points=points, texts=texts)
