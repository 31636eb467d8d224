"""detector: the suite's detector node; the `method` parameter picks a registered detector
(`detectors.DETECTORS`: ssim today), whose parameters are declared beside the node's own.

Subscribes `camera/image_raw` (sensor_msgs/Image: mono8, bgr8, rgb8, bgra8, rgba8) and, by
`pose_source`, `ptz/state` (tracker_msgs/PtzState, the simulator's window rectangle) or
`ptz/joint_states` (sensor_msgs/JointState) + `camera/camera_info` (a real pan-tilt unit). Each
image is paired with the pose of its stamp (`pose_buffer`), handed to the detector as a
`detector.CameraFrame`, and answered by exactly one `detections` (tracker_msgs/BlobArray, scene
frame) with the image's stamp -- empty when nothing can be compared, so a lockstep replay always
gets its acknowledgement. `~/motion_mask` and `~/ssim_map` (mono8 Images in camera pixels,
under the node's own name: /detector/motion_mask by default) are published only while
subscribed. Serves `~/select_region` (tracker_msgs/SelectRegion) for detectors started from a
rectangle.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState
from std_msgs.msg import Header
from vision_msgs.msg import Detection2DArray

from tracker_detect.detector import (
    Blob,
    CameraFrame,
    DeferredLearning,
    Detection,
    Detector,
    DetectorUnavailableError,
    SeededDetector,
    StaleFrameError,
    UnusableViewError,
)
from tracker_detect.detectors import DETECTORS, PLUGIN_GROUP
from tracker_detect.image_pose_pairing import (
    POSE_SOURCES,
    PROJECTIONS,
    ImagePosePairing,
    PairedImage,
    SceneSettings,
)
from tracker_detect.registration import CameraIntrinsics
from tracker_detect.seeding import (
    Guidance,
    Offer,
    OfferResult,
    SeededSession,
    SeedingConfig,
    initial_region,
)
from tracker_detect.target_gate import HeldImage, TargetGate
from tracker_msgs.msg import Blob as BlobMsg
from tracker_msgs.msg import BlobArray, PtzState, Target, Track
from tracker_msgs.srv import SelectRegion
from tracker_msgs_py.codec import (
    MAX_MESSAGE_VALUE,
    NS_PER_S,
    UnsupportedEncodingError,
    array_to_image,
    compressed_to_bgr,
    image_qos,
    image_to_array,
    image_to_bgr,
    joint_values,
    msg_to_rect,
    msg_to_window,
    rect_to_msg,
    result_qos,
    stamp_to_ns,
    usable_value,
)
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.node_main import Health, StartupError, SuiteNode, run_node
from tracker_msgs_py.params import (
    config_from_params,
    declare_parameters,
    param,
    params_of,
    specs_of,
)
from tracker_msgs_py.stamps import Order, StampOrder
from tracker_msgs_py.vision import detections_to_vision


@dataclass(frozen=True)
class DetectorNodeConfig:
    """The detector node's own parameters, beside its method's."""

    pose_source: str = param(
        "ptz_state",
        "camera pose: ptz_state (simulator window), joint_states (+ camera_info: real "
        "pan-tilt unit), none (static camera), estimate (unknown: dead reckoning from the "
        "estimated shifts)",
        choices=POSE_SOURCES,
        read_only=True,
    )
    image_transport: str = param(
        "raw",
        "raw: sensor_msgs/Image on camera/image_raw; compressed: sensor_msgs/CompressedImage "
        "(jpeg, png) on camera/image_raw/compressed, as image_transport and the Axis driver "
        "publish it",
        choices=("raw", "compressed"),
        read_only=True,
    )
    image_projection: str = param(
        "linear",
        "the images: linear (a window of the scene resampled linearly: the simulator's suite "
        "interface) or pinhole (a real camera's: resampled onto the scene's equiangular grid "
        "before detection, so a panning camera's background registers)",
        choices=PROJECTIONS,
    )
    pose_buffer_size: int = param(64, "poses (and images waiting for one) kept", min=2, max=10000)
    pose_max_gap: float = param(
        0.5, "interpolate a pose between two at most this far apart", min=0.0, max=60.0, unit="s"
    )
    joint_names: tuple[str, ...] = param(
        ["pan_joint", "tilt_joint"],
        "pan and tilt joints of JointState",
        validator=lambda v: None if len(v) == 2 else "joint_names needs two names",
    )
    scene_width: int = param(
        0, "joint_states: scene width (0 = the camera image's)", min=0, max=1_000_000, unit="px"
    )
    scene_height: int = param(
        0, "joint_states: scene height (0 = the camera image's)", min=0, max=1_000_000, unit="px"
    )
    scene_focal_length: float = param(
        0.0,
        "joint_states: scene px per radian (0 = the camera's fx)",
        min=0.0,
        max=1e9,
    )
    scene_frame_id: str = param("scene", "frame_id of the detections")
    reliable_images: bool = param(
        False, "reliable QoS for images (lockstep replays)", read_only=True
    )
    seeding: SeedingConfig = params_of(SeedingConfig)
    lockstep_targets: bool = param(
        False,
        "seeded detectors in a lockstep replay: each image waits for the hand-over target of its "
        "stamp (with `handover`) and for `target`'s answer to the image before (with "
        "`guide_from_target`), so a replay gives the same result every time",
        read_only=True,
    )
    target_timeout: float = param(
        1.0,
        "lockstep_targets: an image waits at most this long for the targets",
        min=0.01,
        max=60.0,
        unit="s",
    )

    def problems(self) -> list[str]:
        return []


NODE_PARAMETERS = specs_of(DetectorNodeConfig)

RECENT_FRAMES = 16  # images kept for a hand-over naming an image by its stamp


@dataclass
class Counters:
    """What the node dropped or could not pair, for diagnostics and tests."""

    frames: int = 0
    unsupported_encoding: int = 0
    stale_stamp: int = 0
    without_pose: int = 0
    size_changes: int = 0
    view_restarts: int = 0  # a static-camera method (mog2) restarted: the camera's view moved
    registration_fallbacks: int = 0


class DetectorNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (namespace, parameter_overrides, context...)."""
        super().__init__("detector", **node_options)
        for problem in DETECTORS.load_entry_points(PLUGIN_GROUP):
            self.problems.report("unusable detector plug-in", problem)
        chosen = declare_parameters(self, [DETECTORS.method_spec()])["method"]
        self.method = DETECTORS.get(chosen)
        self.params = declare_parameters(
            self,
            [*self.method.parameters, *NODE_PARAMETERS],
            on_change=self._on_change,
            check_all=self._check,
        )
        self.settings = config_from_params(DetectorNodeConfig, self.params)
        self.detector: Detector = self._build(self._method_values(self.params))
        self.counters = Counters()
        self.pairing = ImagePosePairing(
            self.settings.pose_source,
            self.settings.pose_buffer_size,
            self._max_gap_ns(),
            self._scene_settings(),
            self.settings.image_projection,
        )
        self.image_order = StampOrder()
        self.last_frame: CameraFrame | None = None
        reliable = self.settings.reliable_images
        self.detections_pub = self.create_publisher(BlobArray, "detections", result_qos())
        # the same detections for consumers of vision_msgs, beside wherever detections is remapped
        self.vision_pub = self.create_publisher(
            Detection2DArray, self.detections_pub.topic_name + "_2d", result_qos()
        )
        # private (~/: /detector/motion_mask for a node of the default name), one per detector
        self.mask_pub = self.create_publisher(Image, "~/motion_mask", image_qos(reliable))
        self.ssim_pub = self.create_publisher(Image, "~/ssim_map", image_qos(reliable))
        if self.settings.image_transport == "compressed":  # image_transport's topic name
            self.create_subscription(
                CompressedImage,
                "camera/image_raw/compressed",
                self._on_compressed_image,
                image_qos(reliable),
            )
        else:
            self.create_subscription(Image, "camera/image_raw", self._on_image, image_qos(reliable))
        pose_qos = image_qos(reliable, depth=self.settings.pose_buffer_size)
        source = self.settings.pose_source
        if source == "ptz_state":
            self.create_subscription(PtzState, "ptz/state", self._on_ptz_state, pose_qos)
        elif source == "joint_states":
            self.create_subscription(JointState, "ptz/joint_states", self._on_joint_state, pose_qos)
            self.create_subscription(
                CameraInfo, "camera/camera_info", self._on_camera_info, image_qos(reliable)
            )
        self.create_service(SelectRegion, "~/select_region", self._on_select_region)
        self.recent_frames: dict[int, CameraFrame] = {}
        self.guide: Guidance | None = None
        self.latest_offer: Offer | None = None
        self.gate: TargetGate | None = None
        self.session: SeededSession | None = None
        if isinstance(self.detector, SeededDetector):
            self.session = SeededSession(
                self.detector, self._seeding_config(), self._initial_region()
            )
            self.create_subscription(Target, "target", self._on_target, 10)
            self.create_subscription(Target, "handover_target", self._on_handover_target, 10)
            if self.settings.lockstep_targets:
                self.gate = TargetGate(
                    self.settings.seeding.handover,
                    self.settings.seeding.guide_from_target,
                    self.settings.target_timeout,
                )
                self.create_steady_timer(0.05, self._expire_held_images)
        self.get_logger().info(f"detector ready: method {self.method.name}, pose {source}")

    # --- parameters ---------------------------------------------------------------------------

    def _method_values(self, values: dict[str, Any]) -> dict[str, Any]:
        return {spec.name: values[spec.name] for spec in self.method.parameters}

    def _build(self, values: dict[str, Any]) -> Detector:
        """The method's detector; one that cannot start ends the node with its cause."""
        try:
            return self.method.build(values)
        except DetectorUnavailableError as error:
            raise StartupError(f"the {self.method.name} detector cannot start: {error}") from None

    def _check(self, values: dict[str, Any]) -> str | None:
        try:
            detector = self._build(self._method_values(values))
            settings = config_from_params(DetectorNodeConfig, values)
        except ValueError as error:
            return str(error)
        if settings.pose_source == "estimate" and not detector.estimates_ego_motion:
            return (
                f"pose_source 'estimate' needs a detector that estimates the camera's motion "
                f"({self.method.name} with these parameters does not; for ssim: compensation "
                "ssim_search or phase_correlation)"
            )
        return None

    def _max_gap_ns(self) -> int:
        return round(float(self.settings.pose_max_gap) * NS_PER_S)

    def _scene_settings(self) -> SceneSettings:
        settings = self.settings
        return SceneSettings(
            settings.scene_width, settings.scene_height, settings.scene_focal_length
        )

    @property
    def pending(self) -> ImagePosePairing:
        """The images waiting for their pose (len() is how many)."""
        return self.pairing

    @property
    def camera(self) -> CameraIntrinsics | None:
        return self.pairing.camera

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(DetectorNodeConfig, self.params)
        if any(spec.name in changed for spec in self.method.parameters):
            values = self._method_values(self.params)
            if self.method.config is not None:  # keeps the history it can
                self.detector.reconfigure(self.method.configure(values))
            else:  # a plug-in without a config dataclass: a new detector
                self.detector = self._build(values)
        self.pairing.configure(
            self.settings.pose_buffer_size,
            self._max_gap_ns(),
            self._scene_settings(),
            self.settings.image_projection,
        )
        if self.session is not None and isinstance(self.detector, SeededDetector):
            self.session.detector = self.detector  # rebuilt when it cannot reconfigure
            self.session.config = self._seeding_config()
        if self.gate is not None:
            self.gate.wait_handover = self.settings.seeding.handover
            self.gate.wait_guide = self.settings.seeding.guide_from_target
            self.gate.timeout = self.settings.target_timeout

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        if self.pairing.waiting_for_camera_info:
            state = "waiting for camera_info (pose_source joint_states)"
        elif len(self.pairing):
            state = f"{len(self.pairing)} image(s) waiting for their pose"
        else:
            state = "detecting"
        return state, {"method": self.method.name, "pose source": self.settings.pose_source}

    def diagnostic_health(self) -> tuple[Health, str]:
        if self.pairing.waiting_for_camera_info:
            return Health.WARN, "no camera_info yet: images are answered empty"
        return Health.OK, ""

    # --- inputs -------------------------------------------------------------------------------

    def _on_image(self, msg: Image) -> None:
        self._take_image(
            msg.header,
            lambda: image_to_array(msg) if msg.encoding == "mono8" else image_to_bgr(msg),
        )

    def _on_compressed_image(self, msg: CompressedImage) -> None:
        self._take_image(msg.header, lambda: compressed_to_bgr(msg))

    def _take_image(self, header: Header, decode: Callable[[], np.ndarray]) -> None:
        stamp = stamp_to_ns(header.stamp)
        try:  # before its stamp counts: a dropped image must not move the detector's clock
            pixels = decode()
        except UnsupportedEncodingError as error:
            self.counters.unsupported_encoding += 1
            self.problems.report(
                error.cause,
                f"{error}; such images are answered with an empty BlobArray (when newer than "
                "the last image)",
            )
            if self.image_order.classify(stamp) is Order.NEXT:
                # lockstep: its camera waits for an answer; an older or repeated stamp is not
                # answered, which would move the tracker's clock back or answer an image twice
                self._publish_empty(header)
            return
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
        self._handle(self.pairing.add_image(header, stamp, pixels.copy()))

    def _start_epoch(self, stamp_ns: int) -> None:
        """Time jumped back (a restarted or looping source): forget what the old stamps built."""
        self.get_logger().info(
            f"camera images: {self.image_order.describe_jump()}; a new replay epoch: detection "
            "history and waiting images cleared"
        )
        if self.gate is not None:  # the old epoch's images are answered on the old state
            for held in self.gate.clear():
                self._detect_now(held.item, held.handover)
        self.detector.reset()
        if self.session is not None:
            self.session.reset()
        self.recent_frames.clear()
        self.guide = self.latest_offer = None
        self._handle(self.pairing.new_epoch(stamp_ns))  # still answered once, as every image is

    def _on_ptz_state(self, msg: PtzState) -> None:
        try:
            window = msg_to_window(msg.window)
        except ValueError as error:
            self.problems.report("invalid PtzState window", f"ignored a PtzState window: {error}")
            return
        if not (usable_value(msg.focal_length) and msg.focal_length >= 0.0):
            self.problems.report(
                "unusable focal length",
                f"ignored a PtzState with focal_length {msg.focal_length} (0 or positive, up to "
                f"{MAX_MESSAGE_VALUE:g}, expected)",
            )
            return
        pose = (window.x, window.y, window.width, window.height, msg.focal_length)
        self._handle(self.pairing.add_pose(stamp_to_ns(msg.header.stamp), pose))

    def _on_joint_state(self, msg: JointState) -> None:
        names = list(msg.name)
        wanted = self.settings.joint_names
        positions = joint_values(names, msg.position, wanted)
        if positions is None:
            self.problems.report(
                "JointState without the pan/tilt joints",
                f"ignored a JointState without positions for {list(wanted)} (names {names})",
            )
            return
        pan, tilt = positions
        if not (usable_value(pan) and usable_value(tilt)):
            self.problems.report(
                "unusable joint position",
                f"ignored a JointState with pan/tilt {pan, tilt} (finite, within "
                f"+-{MAX_MESSAGE_VALUE:g}, expected)",
            )
            return
        self._handle(self.pairing.add_pose(stamp_to_ns(msg.header.stamp), (pan, tilt)))

    def _on_camera_info(self, msg: CameraInfo) -> None:
        try:
            camera = CameraIntrinsics.of_camera_info(msg)
        except ValueError as error:
            self.problems.report("invalid CameraInfo", f"ignored a CameraInfo: {error}")
            return
        self._handle(self.pairing.set_camera(camera))

    # --- pairing and detection ----------------------------------------------------------------

    def _handle(self, images: list[PairedImage]) -> None:
        """Detect in each image paired with its pose; answer the others with an empty array."""
        if self.pairing.waiting_for_camera_info:
            self.problems.report(
                "no CameraInfo yet", "waiting for camera/camera_info to use joint states"
            )
        for image in images:
            if image.found:
                self._detect(image)
                continue
            if image.problem:
                self.problems.report("unusable pose", f"unusable pose: {image.problem}")
            self.counters.without_pose += 1
            self.problems.report(
                f"pose {image.status.value}",
                f"no pose for the image stamped {image.stamp_ns} ns ({image.status.value}); "
                "answered with an empty BlobArray",
            )
            self._publish_empty(image.token)

    def _detect(self, image: PairedImage) -> None:
        if self.gate is None:
            self._detect_now(image, None)
            return
        for held in self.gate.add_image(image.stamp_ns, image, time.monotonic()):
            self._release(held)

    def _release(self, held: HeldImage) -> None:
        if held.timed_out:
            self.problems.report(
                "targets late",
                f"processed the image stamped {held.stamp_ns} ns without waiting longer for the "
                f"targets (lockstep_targets; {self.settings.target_timeout} s): is the tracker "
                "running?",
            )
        self._detect_now(held.item, held.handover)

    def _expire_held_images(self) -> None:
        if self.gate is not None:
            for held in self.gate.expire(time.monotonic()):
                self._release(held)

    def _detect_now(self, image: PairedImage, offer: Offer | None) -> None:
        frame = CameraFrame(image.stamp_ns, image.pixels, image.view)
        try:
            if self.session is None:
                detection = self.detector.process(frame)
            else:
                detection = self._seeded_step(self.session, frame, offer)
        except StaleFrameError:
            self.counters.stale_stamp += 1
            return
        except UnusableViewError as error:
            self.problems.report("unusable view", f"answered an image with no detections: {error}")
            self._publish_empty(image.token)
            return
        previous, self.last_frame = self.last_frame, frame
        self.recent_frames[frame.stamp_ns] = frame
        while len(self.recent_frames) > RECENT_FRAMES:
            del self.recent_frames[min(self.recent_frames)]
        self.counters.frames += 1
        if detection.history_reset and (previous is None or previous.size != frame.size):
            self.counters.size_changes += 1
            self.get_logger().info(
                f"image size changed to {frame.size[0]}x{frame.size[1]}: detection history cleared"
            )
        elif detection.history_reset:
            self.counters.view_restarts += 1
            self.problems.report(
                "detector restarted: the view moved",
                f"the {self.method.name} detector restarted its model because the camera's view "
                "moved or zoomed: it is a static-camera method",
            )
        if detection.registration_fallback:
            self.counters.registration_fallbacks += 1
        self._publish_detections(self._blob_array(detection, image.token))
        self._publish_debug(detection, image.token)
        if isinstance(self.detector, DeferredLearning):  # off the image -> detections latency
            self.detector.learn_last_frame()

    # --- seeded detectors: start, hand-over, guidance (seeding.SeededSession) ------------------

    def _seeding_config(self) -> SeedingConfig:
        return self.settings.seeding

    def _initial_region(self) -> Rect | None:
        return initial_region(self.settings.seeding.initial_region)

    def _seeded_step(
        self, session: SeededSession, frame: CameraFrame, offer: Offer | None
    ) -> Detection:
        if offer is None and self.gate is None:  # live: the newest offer, if it is of this image
            latest = self.latest_offer
            offer = latest if latest is not None and latest.stamp_ns == frame.stamp_ns else None
        region = session.pending_region
        step = session.step(frame, offer, self.guide)
        if step.initial is not None:
            self.get_logger().info(f"initial_region {region}: {step.initial}")
        if offer is not None:
            self._report_offer(offer, step.offer)
        return step.detection

    def _report_offer(self, offer: Offer, result: OfferResult | None) -> None:
        if result is None:
            return
        if result.taken:
            self.guide = None  # the old target's guidance belongs to another object
            again = "re-" if result.again else ""
            self.get_logger().info(f"{again}handed over target {offer.track_id} at {offer.box}")
        elif result.refused is not None:
            self.problems.report(
                "hand-over refused", f"hand-over of {offer.box} refused: {result.refused}"
            )

    def _on_target(self, msg: Target) -> None:
        following = msg.locked and msg.track.status != Track.STATUS_LOST  # coasting is fine
        track, stamp = msg.track, stamp_to_ns(msg.header.stamp)
        self.guide = Guidance(stamp, track.x, track.y, track.vx, track.vy) if following else None
        if self.gate is not None:
            for held in self.gate.add_guide(stamp, time.monotonic()):
                self._release(held)

    def _on_handover_target(self, msg: Target) -> None:
        if not self.settings.seeding.handover or self.session is None:
            return
        offer = self._offer(msg)
        if self.gate is not None:  # offered with the image of its stamp when that is processed
            for held in self.gate.add_handover(
                stamp_to_ns(msg.header.stamp), offer, time.monotonic()
            ):
                self._release(held)
            return
        if offer is None:
            return
        self.latest_offer = offer
        frame = self.recent_frames.get(offer.stamp_ns)
        if frame is not None:  # its image was processed already: offer it there
            self._report_offer(offer, self.session.offer(frame, offer))

    def _offer(self, msg: Target) -> Offer | None:
        """The hand-over target as an Offer; None when unlocked or its box is unusable."""
        if not msg.locked:
            return None
        track = msg.track
        try:
            box = msg_to_rect(track.bbox)
        except ValueError as error:
            self.problems.report("invalid hand-over box", f"ignored a hand-over target: {error}")
            return None
        measured = track.status == Track.STATUS_CONFIRMED
        return Offer(stamp_to_ns(msg.header.stamp), int(track.id), box, measured, int(track.hits))

    def _on_select_region(
        self, request: SelectRegion.Request, response: SelectRegion.Response
    ) -> SelectRegion.Response:
        try:
            region = msg_to_rect(request.region)
        except ValueError as error:
            response.success, response.message = False, str(error)
            return response
        if not isinstance(self.detector, SeededDetector):
            response.success = False
            response.message = f"the {self.method.name} detector is not started from a region"
        elif self.last_frame is None:
            response.success, response.message = False, "no camera image yet"
        else:
            reason = self.detector.select_region(region, self.last_frame)
            response.success, response.message = reason is None, reason or "region selected"
        self.get_logger().info(f"select_region {region}: {response.message}")
        return response

    # --- outputs ------------------------------------------------------------------------------

    def _blob_array(self, detection: Detection, image_header: Header) -> BlobArray:
        msg = BlobArray()
        msg.header.stamp = image_header.stamp
        msg.header.frame_id = self.settings.scene_frame_id
        msg.blobs = [_blob_msg(b) for b in detection.blobs]
        msg.target_present = detection.target_present
        msg.compared_area = float(detection.compared_area)
        msg.ego_shift_x, msg.ego_shift_y = (float(v) for v in detection.ego_shift)
        return msg

    def _publish_empty(self, image_header: Header) -> None:
        msg = BlobArray()
        msg.header.stamp = image_header.stamp
        msg.header.frame_id = self.settings.scene_frame_id
        self._publish_detections(msg)

    def _publish_detections(self, msg: BlobArray) -> None:
        """The BlobArray, and as vision_msgs/Detection2DArray on `<detections>_2d` when read."""
        self.detections_pub.publish(msg)
        if self.vision_pub.get_subscription_count():
            self.vision_pub.publish(detections_to_vision(msg))

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


def _blob_msg(blob: Blob) -> BlobMsg:
    msg = BlobMsg(
        centroid_x=blob.centroid_x,
        centroid_y=blob.centroid_y,
        bbox=rect_to_msg(blob.bbox),
        area=round(blob.area),
        score=blob.score,
        label=blob.label,
        angle=blob.angle,
    )
    if blob.oriented_size is not None:
        msg.oriented_width, msg.oriented_height = blob.oriented_size
    return msg


def main(args: list[str] | None = None) -> int:
    return run_node(DetectorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
