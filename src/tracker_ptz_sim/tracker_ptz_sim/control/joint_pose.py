"""The pan-tilt state of each camera image, from a real unit's standard messages (no rclpy).

A pan-tilt driver publishes `sensor_msgs/JointState` (pan, tilt and maybe a zoom joint, at its own
rate) and a camera driver publishes each image with a `sensor_msgs/CameraInfo` of the same stamp.
The suite's detector, tracker and controller want, per image, where the camera looked in scene
pixels (tracker_msgs/PtzState). `JointPoseBridge` makes one `PtzPose` per CameraInfo:

- pan and tilt (and zoom, rates) interpolated between the joint states around the image's stamp
  (`pose_buffer.PoseBuffer`); an image waits until a joint state at or after its stamp has come,
  or is released by `give_up` on the joint state before it (at most `max_age_ns` older), carried
  forward to the image's stamp by the commanded rates when `motion` holds them (a unit that
  reports its joints at 1 Hz, or with zero velocities, while it turns);
- the scene: pan/tilt angles mapped linearly to scene pixels (`SceneGeometry`: x = cx − f·pan,
  y = cy + f·tilt), f = `scene.focal_length` or, when 0, the first CameraInfo's fx divided by the
  zoom of that moment (so scene pixels are camera pixels at zoom 1);
- the window: the scene rectangle the image covers, from the CameraInfo's K (taken as the
  intrinsics of that very image: drivers whose K follows the zoom give exact windows);
- zoom: the zoom joint's position when there is one, else fx / f.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from tracker_detect.image_pose_pairing import SceneSettings
from tracker_detect.pose_buffer import PoseBuffer, PoseLookup, PoseStatus
from tracker_detect.registration import CameraIntrinsics, view_from_pan_tilt
from tracker_msgs_py.geometry import Rect, SceneGeometry
from tracker_ptz_sim.control.unit_joints import CommandedMotion

MOVING_RATE = 1e-3  # rad/s: slower joints count as still


@dataclass(frozen=True)
class PtzPose:
    """What a PtzState reports for one image."""

    stamp_ns: int
    pan: float  # rad, REP-103 (positive = left)
    tilt: float  # rad (positive = down)
    pan_rate: float  # rad/s
    tilt_rate: float
    zoom: float
    focal_length: float  # scene px per rad at zoom 1
    window: Rect  # scene px
    moving: bool


@dataclass(frozen=True)
class JointSample:
    """One JointState of the unit; rates NaN when the driver gives no velocities."""

    stamp_ns: int
    pan: float
    tilt: float
    zoom: float = math.nan
    pan_rate: float = math.nan
    tilt_rate: float = math.nan


class JointPoseBridge:
    """See the module docstring. Every CameraInfo added is released exactly once: as a pose,
    or as None with the reason (`dropped`)."""

    def __init__(
        self,
        scene: SceneSettings | None = None,
        capacity: int = 64,
        max_gap_ns: int = 500_000_000,
        max_age_ns: int = 500_000_000,
        motion: CommandedMotion | None = None,
    ) -> None:
        self.scene = scene or SceneSettings()
        self.motion = motion  # the commanded rates, to carry the latest joint state forward
        self.joints = PoseBuffer(capacity, max_gap_ns)
        self.max_age_ns = max_age_ns
        self.focal_length: float | None = None  # fixed by the settings or the first CameraInfo
        self.waiting: deque[tuple[int, CameraIntrinsics]] = deque()
        self.dropped: list[tuple[int, str]] = []  # (stamp, why), for the caller to report
        self._has_zoom = False
        self._previous: JointSample | None = None

    def add_joints(self, sample: JointSample) -> list[PtzPose]:
        """A joint state; returns the waiting images it lets go."""
        sample = self._with_rates(sample)
        newest = self.joints.newest_stamp
        if newest is not None and sample.stamp_ns < newest:
            self.joints.drop_after(sample.stamp_ns)  # time jumped back: a new epoch
        self._has_zoom = math.isfinite(sample.zoom)
        zoom = sample.zoom if self._has_zoom else 1.0
        values = (sample.pan, sample.tilt, zoom, sample.pan_rate, sample.tilt_rate)
        self.joints.add(sample.stamp_ns, values)
        return self._drain(give_up=False)

    def add_camera_info(self, stamp_ns: int, camera: CameraIntrinsics) -> list[PtzPose]:
        """The CameraInfo of an image; returns the poses now known (this image's, if it is)."""
        self.waiting.append((stamp_ns, camera))
        return self._drain(give_up=False)

    def give_up(self) -> list[PtzPose]:
        """Release every waiting image on the latest joint state before it (a unit that stopped
        publishing, or publishes only on change), or drop it when that is too old."""
        return self._drain(give_up=True)

    def _with_rates(self, sample: JointSample) -> JointSample:
        previous, self._previous = self._previous, sample
        if math.isfinite(sample.pan_rate) and math.isfinite(sample.tilt_rate):
            return sample
        if previous is None or sample.stamp_ns <= previous.stamp_ns:
            pan_rate = tilt_rate = 0.0
        else:
            dt = (sample.stamp_ns - previous.stamp_ns) * 1e-9
            pan_rate = (sample.pan - previous.pan) / dt
            tilt_rate = (sample.tilt - previous.tilt) / dt
        return JointSample(
            sample.stamp_ns, sample.pan, sample.tilt, sample.zoom, pan_rate, tilt_rate
        )

    def _drain(self, give_up: bool) -> list[PtzPose]:
        released = []
        while self.waiting:
            stamp, camera = self.waiting[0]
            found = self.joints.lookup(stamp)
            if found.status is PoseStatus.WAIT and give_up:
                found = self._latest_before(stamp)
            if found.status is PoseStatus.WAIT:
                break
            self.waiting.popleft()
            if found.values is None:
                why = (
                    "no JointState received yet"
                    if self.joints.newest_stamp is None
                    else "no JointState near the image's stamp"
                )
                self.dropped.append((stamp, why))
                continue
            released.append(self._pose(stamp, camera, found.values))
        return released

    def _latest_before(self, stamp_ns: int) -> PoseLookup:
        newest = self.joints.newest_stamp
        if newest is None or stamp_ns - newest > self.max_age_ns:
            return PoseLookup(PoseStatus.MISSING)
        found = self.joints.lookup(newest)
        motion = self.motion
        commanded = None if motion is None else motion.rate_at(stamp_ns)
        if found.values is None or motion is None or commanded is None:
            return found
        pan, tilt, zoom = found.values[:3]
        pan_travel, tilt_travel = motion.travel(newest, stamp_ns)
        return PoseLookup(found.status, (pan + pan_travel, tilt + tilt_travel, zoom, *commanded))

    def _pose(self, stamp_ns: int, camera: CameraIntrinsics, values: tuple[float, ...]) -> PtzPose:
        pan, tilt, joint_zoom, pan_rate, tilt_rate = values
        if self.focal_length is None:
            self.focal_length = self.scene.focal_length or camera.fx / joint_zoom
        focal = self.focal_length
        zoom = joint_zoom if self._has_zoom else camera.fx / focal
        geometry = SceneGeometry(
            self.scene.width or camera.width, self.scene.height or camera.height, focal
        )
        window = view_from_pan_tilt(pan, tilt, camera, geometry).rect
        moving = max(abs(pan_rate), abs(tilt_rate)) > MOVING_RATE
        return PtzPose(stamp_ns, pan, tilt, pan_rate, tilt_rate, zoom, focal, window, moving)
