"""ssim_detector: SSIM motion detection behind a pan-tilt camera (thin shell over motion.py).

Subscribes `camera/image_raw` (sensor_msgs/Image: mono8, bgr8 or rgb8) and, by `pose_source`,
`ptz/state` (tracker_msgs/PtzState, the simulator's window rectangle) or `ptz/joint_states`
(sensor_msgs/JointState) + `camera/camera_info` (a real pan-tilt unit). Each image is paired with
the pose of its stamp, compared with the image `gap` frames earlier, and answered by exactly one
`detections` (tracker_msgs/BlobArray, scene frame) with the image's stamp -- empty when nothing
can be compared, so a lockstep replay always gets its acknowledgement. `detector/motion_mask`
and `detector/ssim_map` (mono8 Images in camera pixels) are published only while subscribed.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_msgs.msg import Header

from tracker_detect.motion import (
    COMPENSATION_MODES,
    ESTIMATORS,
    KERNEL_SHAPES,
    MORPHOLOGY_STEPS,
    SEED_MORPHOLOGY,
    Detection,
    DetectorConfig,
    MotionDetector,
    StaleFrameError,
)
from tracker_detect.pose_buffer import PoseBuffer, PoseStatus
from tracker_detect.registration import CameraIntrinsics, View, view_from_pan_tilt
from tracker_msgs.msg import Blob as BlobMsg
from tracker_msgs.msg import BlobArray, PtzState
from tracker_msgs_py.codec import (
    UnsupportedEncodingError,
    array_to_image,
    image_qos,
    image_to_gray,
    msg_to_window,
    rect_to_msg,
    stamp_to_ns,
)
from tracker_msgs_py.geometry import Rect, SceneGeometry
from tracker_msgs_py.node_main import SuiteNode, run_node
from tracker_msgs_py.params import ParamSpec, declare_parameters
from tracker_msgs_py.stamps import Order, StampOrder

POSE_SOURCES = ("ptz_state", "joint_states", "none", "estimate")
_D = DetectorConfig()

PARAMS = [
    ParamSpec("gap", _D.gap, "frames between the compared images (seed: 3)", 1, 100),
    ParamSpec("threshold", _D.threshold, "SSIM at or below which a pixel is motion", -1.0, 1.0),
    ParamSpec(
        "morphology",
        list(SEED_MORPHOLOGY),
        "mask clean-up steps in order, each one of: " + ", ".join(MORPHOLOGY_STEPS),
        validator=lambda v: (
            None
            if all(s in MORPHOLOGY_STEPS for s in v)
            else f"morphology steps must be among {', '.join(MORPHOLOGY_STEPS)}"
        ),
    ),
    ParamSpec(
        "kernel_shape",
        _D.kernel_shape,
        "dilation element ('seed' = the thesis' 7x7 H)",
        choices=KERNEL_SHAPES,
    ),
    ParamSpec(
        "kernel_size",
        _D.kernel_size,
        "odd side of the element for shapes other than 'seed' [px]",
        1,
        51,
        validator=lambda v: None if v % 2 else "kernel_size must be odd",
    ),
    ParamSpec(
        "connectivity",
        _D.connectivity,
        "blob pixel connectivity (4 or 8)",
        4,
        8,
        validator=lambda v: None if v in (4, 8) else "connectivity must be 4 or 8",
    ),
    ParamSpec(
        "presence_fraction",
        _D.presence_fraction,
        "presence test: total blob area >= this fraction of the compared area",
        0.0,
        1.0,
    ),
    ParamSpec(
        "min_blob_area", _D.min_blob_area, "drop blobs smaller than this [scene px^2]", 0.0, 1e9
    ),
    ParamSpec(
        "pose_source",
        "ptz_state",
        "camera pose: ptz_state (simulator window), joint_states (+ camera_info: real "
        "pan-tilt unit), none (static camera), estimate (unknown: dead reckoning from the "
        "estimated shifts)",
        choices=POSE_SOURCES,
        read_only=True,
    ),
    ParamSpec(
        "compensation",
        _D.compensation,
        "ego-motion compensation: known (from the poses), ssim_search (seed's exhaustive "
        "simplified-SSIM search), phase_correlation, off",
        choices=COMPENSATION_MODES,
    ),
    ParamSpec("search_radius", _D.search_radius, "shift estimators search +- this [px]", 0, 200),
    ParamSpec(
        "search_window", _D.search_window, "uniform window of the simplified SSIM [px]", 1, 31
    ),
    ParamSpec(
        "search_pyramid_levels",
        _D.search_pyramid_levels,
        "coarse-to-fine levels of ssim_search (0 = the seed's full-resolution search)",
        0,
        5,
    ),
    ParamSpec(
        "phase_candidates",
        _D.phase_candidates,
        "phase_correlation: peaks verified by the simplified SSIM",
        1,
        50,
    ),
    ParamSpec(
        "subpixel_alignment",
        _D.subpixel_alignment,
        "resample fractional shifts bilinearly (else round them)",
    ),
    ParamSpec(
        "auto_downsample",
        _D.auto_downsample,
        "Wang's automatic downsampling, f = round(min(H, W) / 256)",
    ),
    ParamSpec(
        "min_overlap_fraction",
        _D.min_overlap_fraction,
        "compare only when the aligned images overlap at least this much",
        0.01,
        1.0,
    ),
    ParamSpec(
        "double_detection",
        _D.double_detection,
        "also compare with the frame where motion began (slow / stopped objects)",
    ),
    ParamSpec(
        "reference_max_age",
        _D.reference_max_age,
        "frames a double-detection reference is kept at most",
        1,
        100000,
    ),
    ParamSpec("pose_buffer_size", 64, "poses (and images waiting for one) kept", 2, 10000),
    ParamSpec(
        "pose_max_gap", 0.5, "interpolate a pose between two at most this far apart [s]", 0.0, 60.0
    ),
    ParamSpec(
        "joint_names",
        ["pan_joint", "tilt_joint"],
        "pan and tilt joints of JointState",
        validator=lambda v: None if len(v) == 2 else "joint_names needs two names",
    ),
    ParamSpec(
        "scene_width", 0, "joint_states: scene width [px] (0 = the camera image's)", 0, 1_000_000
    ),
    ParamSpec(
        "scene_height", 0, "joint_states: scene height [px] (0 = the camera image's)", 0, 1_000_000
    ),
    ParamSpec(
        "scene_focal_length",
        0.0,
        "joint_states: scene px per radian (0 = the camera's fx)",
        0.0,
        1e9,
    ),
    ParamSpec("scene_frame_id", "scene", "frame_id of the detections"),
    ParamSpec(
        "reliable_images", False, "reliable QoS for images (lockstep replays)", read_only=True
    ),
]

_CONFIG_PARAMS = {
    "gap",
    "threshold",
    "kernel_shape",
    "kernel_size",
    "connectivity",
    "presence_fraction",
    "min_blob_area",
    "compensation",
    "search_radius",
    "search_window",
    "search_pyramid_levels",
    "phase_candidates",
    "subpixel_alignment",
    "auto_downsample",
    "min_overlap_fraction",
    "double_detection",
    "reference_max_age",
}


def detector_config(values: dict[str, Any]) -> DetectorConfig:
    """The DetectorConfig the parameters describe (raises ValueError when invalid)."""
    return replace(
        _D,
        **{k: v for k, v in values.items() if k in _CONFIG_PARAMS},
        morphology=tuple(values["morphology"]),
    )


def _check(values: dict[str, Any]) -> str | None:
    try:
        config = detector_config(values)
    except ValueError as error:
        return str(error)
    if values["pose_source"] == "estimate" and config.compensation not in ESTIMATORS:
        return "pose_source 'estimate' needs compensation ssim_search or phase_correlation"
    return None


@dataclass
class _PendingImage:
    header: Header
    stamp_ns: int
    gray: np.ndarray


@dataclass
class Counters:
    """What the node dropped or could not pair, for diagnostics and tests."""

    frames: int = 0
    unsupported_encoding: int = 0
    stale_stamp: int = 0
    without_pose: int = 0
    size_changes: int = 0
    registration_fallbacks: int = 0


class SsimDetectorNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (namespace, parameter_overrides, context...)."""
        super().__init__("ssim_detector", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change, check_all=_check)
        self.detector = MotionDetector(detector_config(self.params))
        self.counters = Counters()
        self.poses = PoseBuffer(self.params["pose_buffer_size"], self._max_gap_ns())
        self.pending: deque[_PendingImage] = deque()
        self.camera: CameraIntrinsics | None = None
        self.image_order = StampOrder()
        reliable = self.params["reliable_images"]
        self.detections_pub = self.create_publisher(BlobArray, "detections", 10)
        self.mask_pub = self.create_publisher(Image, "detector/motion_mask", image_qos(reliable))
        self.ssim_pub = self.create_publisher(Image, "detector/ssim_map", image_qos(reliable))
        self.create_subscription(Image, "camera/image_raw", self._on_image, image_qos(reliable))
        pose_qos = image_qos(reliable, depth=self.params["pose_buffer_size"])
        source = self.params["pose_source"]
        if source == "ptz_state":
            self.create_subscription(PtzState, "ptz/state", self._on_ptz_state, pose_qos)
        elif source == "joint_states":
            self.create_subscription(JointState, "ptz/joint_states", self._on_joint_state, pose_qos)
            self.create_subscription(
                CameraInfo, "camera/camera_info", self._on_camera_info, image_qos(reliable)
            )

    # --- parameters ---------------------------------------------------------------------------

    def _max_gap_ns(self) -> int:
        return round(self.params["pose_max_gap"] * 1e9)

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.detector.reconfigure(detector_config(self.params))
        if "pose_buffer_size" in changed or "pose_max_gap" in changed:
            self.poses.capacity = self.params["pose_buffer_size"]
            self.poses.max_gap_ns = self._max_gap_ns()

    # --- inputs -------------------------------------------------------------------------------

    def _on_image(self, msg: Image) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        order = self.image_order.check(stamp)
        if order in (Order.REPEAT, Order.INVALID):
            self.counters.stale_stamp += 1
            self.problems.report(
                f"{order.value} image stamp",
                f"dropped an image stamped {stamp} ns ({order.value}): every image is answered "
                "once",
            )
            return
        if order is Order.NEW_EPOCH:
            self._start_epoch(stamp)
        try:
            gray = image_to_gray(msg)
        except UnsupportedEncodingError as error:
            self.counters.unsupported_encoding += 1
            self.problems.report(
                error.cause, f"{error}; such images are answered with an empty BlobArray"
            )
            self._publish_empty(msg.header)
            return
        self.pending.append(_PendingImage(msg.header, stamp, gray.copy()))
        self._drain()

    def _start_epoch(self, stamp_ns: int) -> None:
        """Time jumped back (a restarted or looping source): forget what the old stamps built."""
        self.get_logger().info(
            f"camera images: {self.image_order.describe_jump()}; a new replay epoch: detection "
            "history and waiting images cleared"
        )
        for image in self.pending:
            self._publish_empty(image.header)  # still answered once, as every image is
        self.pending.clear()
        self.detector.reset()
        self.poses.drop_after(stamp_ns)

    def _add_pose(self, stamp_ns: int, values: tuple[float, ...]) -> None:
        newest = self.poses.newest_stamp
        if newest is not None and stamp_ns < newest:
            self.poses.drop_after(stamp_ns)  # the pose stream jumped back: a new epoch
        self.poses.add(stamp_ns, values)
        self._drain()

    def _on_ptz_state(self, msg: PtzState) -> None:
        try:
            window = msg_to_window(msg.window)
        except ValueError as error:
            self.problems.report("invalid PtzState window", f"ignored a PtzState window: {error}")
            return
        self._add_pose(
            stamp_to_ns(msg.header.stamp), (window.x, window.y, window.width, window.height)
        )

    def _on_joint_state(self, msg: JointState) -> None:
        names = list(msg.name)
        wanted = self.params["joint_names"]
        try:
            pan, tilt = (float(msg.position[names.index(n)]) for n in wanted)
        except (ValueError, IndexError):
            self.problems.report(
                "JointState without the pan/tilt joints",
                f"ignored a JointState without positions for {wanted} (names {names})",
            )
            return
        if not (math.isfinite(pan) and math.isfinite(tilt)):
            self.problems.report(
                "non-finite joint position",
                f"ignored a JointState with non-finite pan/tilt {pan, tilt}",
            )
            return
        self._add_pose(stamp_to_ns(msg.header.stamp), (pan, tilt))

    def _on_camera_info(self, msg: CameraInfo) -> None:
        try:
            self.camera = CameraIntrinsics(
                int(msg.width),
                int(msg.height),
                float(msg.k[0]),
                float(msg.k[4]),
                float(msg.k[2]),
                float(msg.k[5]),
            )
        except ValueError as error:
            self.problems.report("invalid CameraInfo", f"ignored a CameraInfo: {error}")
            return
        self._drain()

    # --- pairing and detection ----------------------------------------------------------------

    def _drain(self) -> None:
        """Process the waiting images, oldest first, as far as their poses are known."""
        while self.pending:
            image = self.pending[0]
            view, status = self._view_for(image)
            if status is PoseStatus.WAIT and len(self.pending) <= self.params["pose_buffer_size"]:
                return
            self.pending.popleft()
            if status is PoseStatus.FOUND:
                self._detect(image, view)
            else:
                self.counters.without_pose += 1
                self.problems.report(
                    f"pose {status.value}",
                    f"no pose for the image stamped {image.stamp_ns} ns ({status.value}); "
                    "answered with an empty BlobArray",
                )
                self._publish_empty(image.header)

    def _view_for(self, image: _PendingImage) -> tuple[View | None, PoseStatus]:
        height, width = image.gray.shape
        source = self.params["pose_source"]
        if source == "none":
            return View.identity(width, height), PoseStatus.FOUND
        if source == "estimate":
            return None, PoseStatus.FOUND
        if source == "joint_states" and self.camera is None:
            self.problems.report(
                "no CameraInfo yet", "waiting for camera/camera_info to use joint states"
            )
            return None, PoseStatus.WAIT
        found = self.poses.lookup(image.stamp_ns)
        if found.status is not PoseStatus.FOUND:
            return None, found.status
        try:
            if source == "ptz_state":
                return View(Rect(*found.values), width, height), PoseStatus.FOUND
            return view_from_pan_tilt(
                *found.values, self._camera_for(width, height), self._scene_geometry(width, height)
            ), PoseStatus.FOUND
        except ValueError as error:
            self.problems.report("unusable pose", f"unusable pose: {error}")
            return None, PoseStatus.MISSING

    def _camera_for(self, width: int, height: int) -> CameraIntrinsics:
        camera = self.camera
        if (camera.width, camera.height) != (width, height):
            # CameraInfo without a size (0) or from another resolution: scale K to the image.
            sx = width / camera.width if camera.width else 1.0
            sy = height / camera.height if camera.height else 1.0
            camera = CameraIntrinsics(
                width, height, camera.fx * sx, camera.fy * sy, camera.cx * sx, camera.cy * sy
            )
        return camera

    def _scene_geometry(self, width: int, height: int) -> SceneGeometry:
        focal = self.params["scene_focal_length"] or self._camera_for(width, height).fx
        return SceneGeometry(
            self.params["scene_width"] or width, self.params["scene_height"] or height, focal
        )

    def _detect(self, image: _PendingImage, view: View | None) -> None:
        try:
            detection = self.detector.process(image.gray, image.stamp_ns, view)
        except StaleFrameError:
            self.counters.stale_stamp += 1
            return
        self.counters.frames += 1
        if detection.history_reset:
            self.counters.size_changes += 1
            self.get_logger().info(
                f"image size changed to {image.gray.shape[1]}x"
                f"{image.gray.shape[0]}: detection history cleared"
            )
        if detection.registration_fallback:
            self.counters.registration_fallbacks += 1
        self.detections_pub.publish(self._blob_array(detection, image.header))
        self._publish_debug(detection, image.header)

    # --- outputs ------------------------------------------------------------------------------

    def _blob_array(self, detection: Detection, image_header: Header) -> BlobArray:
        msg = BlobArray()
        msg.header.stamp = image_header.stamp
        msg.header.frame_id = self.params["scene_frame_id"]
        msg.blobs = [
            BlobMsg(
                centroid_x=b.centroid_x,
                centroid_y=b.centroid_y,
                bbox=rect_to_msg(b.bbox),
                area=round(b.area),
                score=b.score,
            )
            for b in detection.blobs
        ]
        msg.target_present = detection.target_present
        msg.compared_area = float(detection.compared_area)
        msg.ego_shift_x, msg.ego_shift_y = (float(v) for v in detection.ego_shift)
        return msg

    def _publish_empty(self, image_header: Header) -> None:
        msg = BlobArray()
        msg.header.stamp = image_header.stamp
        msg.header.frame_id = self.params["scene_frame_id"]
        self.detections_pub.publish(msg)

    def _publish_debug(self, detection: Detection, image_header: Header) -> None:
        frame_id = image_header.frame_id
        if detection.mask is not None and self.mask_pub.get_subscription_count() > 0:
            self.mask_pub.publish(
                array_to_image(
                    detection.mask * np.uint8(255), "mono8", image_header.stamp, frame_id
                )
            )
        if detection.similarity is not None and self.ssim_pub.get_subscription_count() > 0:
            grey = np.clip(detection.similarity * 255.0, 0.0, 255.0).astype(np.uint8)
            self.ssim_pub.publish(array_to_image(grey, "mono8", image_header.stamp, frame_id))


def main(args: list[str] | None = None) -> int:
    return run_node(SsimDetectorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
