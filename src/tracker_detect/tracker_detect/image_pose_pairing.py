"""Pairs each camera image with where the camera looked when it was taken (no rclpy).

The detector node's inputs: images, and, by `pose_source`,
- ``ptz_state``: the window rectangle per stamp (x, y, width, height, scene px) and the scene's
  focal length (scene px per rad);
- ``joint_states``: a real unit's pan and tilt per stamp, turned into a view with the camera's
  intrinsics (CameraInfo) and the scene mapping (`SceneGeometry`);
- ``none``: a static camera (the image is the scene);
- ``estimate``: unknown; the detector dead-reckons the view from its own shift estimates.

With `projection` "pinhole" the images are a real camera's and are resampled onto the linear
grid of their view first (`pinhole.to_equiangular`); "linear": they are a linear window of the
scene already (the simulator's suite interface).

`ImagePosePairing` keeps images waiting until their pose is known (`pose_buffer.PoseBuffer`,
interpolated between poses at most `max_gap_ns` apart) and releases them in arrival order as
`PairedImage`s: with a view (`found`), or without one when the pose will never come (a pose older
than every one kept, a gap too long, an unusable pose, or more than `capacity` images waiting).
Every image added is released exactly once.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from tracker_detect.pinhole import to_equiangular
from tracker_detect.pose_buffer import PoseBuffer, PoseStatus
from tracker_detect.registration import CameraIntrinsics, View, view_from_pan_tilt
from tracker_msgs_py.geometry import Rect, SceneGeometry

POSE_SOURCES = ("ptz_state", "joint_states", "none", "estimate")
PROJECTIONS = ("linear", "pinhole")


@dataclass
class PairedImage:
    """An image released by the pairing; `token` is whatever the caller attached (a header)."""

    token: Any
    stamp_ns: int
    pixels: np.ndarray
    status: PoseStatus  # FOUND, or MISSING / WAIT (given up waiting)
    view: View | None = None  # None with FOUND: the pose is to be estimated
    problem: str = ""  # why an unusable pose was unusable

    @property
    def found(self) -> bool:
        return self.status is PoseStatus.FOUND


@dataclass(frozen=True)
class SceneSettings:
    """joint_states only: scene size (0 = the camera image's) and scene px per radian (0 = the
    camera's fx)."""

    width: int = 0
    height: int = 0
    focal_length: float = 0.0


class ImagePosePairing:
    """See the module docstring."""

    def __init__(
        self,
        pose_source: str,
        capacity: int = 64,
        max_gap_ns: int = 0,
        scene: SceneSettings | None = None,
        projection: str = "linear",
    ) -> None:
        if pose_source not in POSE_SOURCES:
            raise ValueError(f"pose_source must be one of {', '.join(POSE_SOURCES)}")
        self.pose_source = pose_source
        self.poses = PoseBuffer(capacity, max_gap_ns)
        self.configure(capacity, max_gap_ns, scene or SceneSettings(), projection)
        self.camera: CameraIntrinsics | None = None
        self._pending: deque[tuple[Any, int, np.ndarray]] = deque()

    def __len__(self) -> int:
        return len(self._pending)

    @property
    def waiting_for_camera_info(self) -> bool:
        return self.pose_source == "joint_states" and self.camera is None and bool(self._pending)

    def configure(
        self, capacity: int, max_gap_ns: int, scene: SceneSettings, projection: str = "linear"
    ) -> None:
        if projection not in PROJECTIONS:
            raise ValueError(f"projection must be one of {', '.join(PROJECTIONS)}")
        self.poses.capacity, self.poses.max_gap_ns, self.scene = capacity, max_gap_ns, scene
        self.projection = projection

    def add_image(self, token: Any, stamp_ns: int, pixels: np.ndarray) -> list[PairedImage]:
        self._pending.append((token, stamp_ns, pixels))
        return self._drain()

    def add_pose(self, stamp_ns: int, values: tuple[float, ...]) -> list[PairedImage]:
        """A window and focal length (x, y, w, h, f) or pan, tilt (rad) at `stamp_ns`; a stamp
        older than the newest pose starts a new epoch of the pose stream (the newer poses are
        forgotten)."""
        newest = self.poses.newest_stamp
        if newest is not None and stamp_ns < newest:
            self.poses.drop_after(stamp_ns)
        self.poses.add(stamp_ns, values)
        return self._drain()

    def set_camera(self, camera: CameraIntrinsics) -> list[PairedImage]:
        self.camera = camera
        return self._drain()

    def new_epoch(self, stamp_ns: int) -> list[PairedImage]:
        """Images went back in time: the waiting images are released without a view (each is
        still answered once) and the poses after `stamp_ns` forgotten."""
        released = [
            PairedImage(token, stamp, pixels, PoseStatus.MISSING)
            for token, stamp, pixels in self._pending
        ]
        self._pending.clear()
        self.poses.drop_after(stamp_ns)
        return released

    def _drain(self) -> list[PairedImage]:
        released = []
        while self._pending:
            token, stamp, pixels = self._pending[0]
            paired = self._pair(token, stamp, pixels)
            if paired.status is PoseStatus.WAIT and len(self._pending) <= self.poses.capacity:
                break
            self._pending.popleft()
            released.append(paired)
        return released

    def _pair(self, token: Any, stamp_ns: int, pixels: np.ndarray) -> PairedImage:
        height, width = pixels.shape[:2]
        source = self.pose_source
        if source in ("none", "estimate"):
            view = View.identity(width, height) if source == "none" else None
            return PairedImage(token, stamp_ns, pixels, PoseStatus.FOUND, view)
        if source == "joint_states" and self.camera is None:
            return PairedImage(token, stamp_ns, pixels, PoseStatus.WAIT)
        found = self.poses.lookup(stamp_ns)
        if found.status is not PoseStatus.FOUND or found.values is None:
            return PairedImage(token, stamp_ns, pixels, found.status)
        try:
            view, focal = self._view(found.values, width, height)
            if self.projection == "pinhole":
                if not focal > 0.0:
                    raise ValueError(f"a pinhole image needs the scene's focal length, got {focal}")
                pixels = to_equiangular(pixels, (view.rect.width, view.rect.height), focal)
        except ValueError as error:
            return PairedImage(token, stamp_ns, pixels, PoseStatus.MISSING, problem=str(error))
        return PairedImage(token, stamp_ns, pixels, PoseStatus.FOUND, view)

    def _view(self, values: tuple[float, ...], width: int, height: int) -> tuple[View, float]:
        """The image's view and the scene's focal length [scene px per rad]."""
        if self.pose_source == "ptz_state":
            x, y, w, h, focal = values
            return View(Rect(x, y, w, h), width, height), focal
        pan, tilt = values
        camera = self.camera_for(width, height)
        focal = self.scene.focal_length or camera.fx
        scene = SceneGeometry(self.scene.width or width, self.scene.height or height, focal)
        return view_from_pan_tilt(pan, tilt, camera, scene), focal

    def camera_for(self, width: int, height: int) -> CameraIntrinsics:
        """The CameraInfo's intrinsics for an image of this size (K scaled when the CameraInfo
        has no size (0) or another resolution)."""
        camera = self.camera
        if camera is None:
            raise ValueError("no CameraInfo yet")
        if (camera.width, camera.height) != (width, height):
            sx = width / camera.width if camera.width else 1.0
            sy = height / camera.height if camera.height else 1.0
            camera = CameraIntrinsics(
                width, height, camera.fx * sx, camera.fy * sy, camera.cx * sx, camera.cy * sy
            )
        return camera
