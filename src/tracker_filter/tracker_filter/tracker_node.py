"""tracker node: detections in, tracks and the pan-tilt target out, one of each per BlobArray.

The `method` parameter picks a registered tracker (`trackers.TRACKERS`); its parameters are
declared beside the node's own. Subscribes detections (tracker_msgs/BlobArray, scene frame) and
ptz/state (tracker_msgs/PtzState, for the view centre), plus what the tracker `needs`:
camera/image_raw (sensor_msgs/Image), detector/motion_mask (mono8 Image), the ptz/state window,
paired with the detections by stamp (`tracker_msgs_py.pairing`). Publishes tracks
(tracker_msgs/TrackArray) and target (tracker_msgs/Target) stamped with the BlobArray's stamp;
serves ~/select_target and ~/reset_tracker (under the node's name: /tracker/select_target by
default). All the tracking is in the core modules; this file
declares parameters, converts messages and wires topics.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
from sensor_msgs.msg import Image
from std_msgs.msg import Header
from vision_msgs.msg import Detection2DArray

from tracker_filter.models import extrapolate_positions
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.selection import (
    SELECTION_DEFAULTS,
    SELECTION_PARAMETERS,
    SelectionConfig,
    SelectionPolicy,
)
from tracker_filter.trackers import PLUGIN_GROUP, TRACKERS
from tracker_filter.tracking import Tracker, TrackSet
from tracker_filter.zones import Zones, parse_polygons
from tracker_msgs.msg import Blob as BlobMsg
from tracker_msgs.msg import BlobArray, PtzState, Rect, Target, Track, TrackArray
from tracker_msgs.srv import ResetTracker, SelectTarget
from tracker_msgs_py.codec import (
    MAX_MESSAGE_VALUE,
    NS_PER_S,
    UnsupportedEncodingError,
    float64_sequence,
    image_qos,
    image_to_array,
    image_to_bgr,
    msg_to_rect,
    msg_to_window,
    result_qos,
    stamp_to_ns,
    usable_value,
)
from tracker_msgs_py.node_main import SuiteNode, run_node
from tracker_msgs_py.pairing import Frame, FrameAssembler
from tracker_msgs_py.params import (
    ParameterError,
    ParamSpec,
    config_from_params,
    declare_parameters,
    param,
    specs_of,
)
from tracker_msgs_py.registry import Method
from tracker_msgs_py.stamps import Order, StampOrder
from tracker_msgs_py.vision import tracks_to_vision

#: Parameters that take effect without rebuilding the tracker (the others clear its tracks).
LIVE_PARAMETERS = frozenset(SELECTION_DEFAULTS) | {
    "scene_frame_id",
    "max_input_gap",
    "ignore_zones",
    "required_zones",
}


def detections_from_msg(msg: BlobArray) -> Detections:
    """The BlobArray's blobs as Detections; none when the detector's presence test failed."""
    return Detections.from_blobs(msg.blobs, msg.target_present)


def has_usable_orientation(blob: BlobMsg) -> bool:
    """Whether a Blob's oriented box is usable (`usable_value`, sides not negative): the trackers
    do not read it, but a blob with a corrupt value anywhere is not a measurement
    (`Detections.invalid_by_cause` checks the rest)."""
    sides = (blob.oriented_width, blob.oriented_height)
    return all(map(usable_value, (blob.angle, *sides))) and min(sides) >= 0.0


def track_to_msg(tracks: TrackSet, i: int) -> Track:
    return tracks_to_msgs(tracks, slice(i, i + 1))[0]


def tracks_to_msgs(tracks: TrackSet, which: slice = slice(None)) -> list[Track]:
    """Track messages of the tracks `which` selects. The fields are taken out of the arrays for
    all of them at once: per track, numpy scalar access cost ~8x the message's construction."""
    means, covariances, layout = tracks.means[which], tracks.covariances[which], tracks.layout
    layout_text = layout.text
    positions = layout.positions(means).tolist()
    velocities = layout.velocities(means).tolist()
    position_covariances = layout.position_covariances(covariances).reshape(-1, 4)
    boxes = tracks.bboxes[which].copy()
    boxes[:, 2:] = np.maximum(boxes[:, 2:], 0.0)
    columns = zip(
        tracks.ids[which].tolist(),
        tracks.status[which].tolist(),
        positions,
        velocities,
        position_covariances,
        means,
        covariances,
        boxes.tolist(),
        tracks.existence[which].tolist(),
        tracks.ages[which].tolist(),
        tracks.hits[which].tolist(),
        tracks.misses[which].tolist(),
        tracks.labels[which].tolist(),
        tracks.scores[which].tolist(),
        strict=True,
    )
    return [
        Track(
            id=track_id,
            status=status,
            x=x,
            y=y,
            vx=vx,
            vy=vy,
            position_covariance=position_covariance,
            state_layout=layout_text,
            state=float64_sequence(mean),
            covariance=float64_sequence(covariance),
            bbox=Rect(x=bx, y=by, width=bw, height=bh),
            existence=existence,
            age=age,
            hits=hits,
            consecutive_misses=misses,
            label=label,
            score=score,
        )
        for (
            track_id,
            status,
            (x, y),
            (vx, vy),
            position_covariance,
            mean,
            covariance,
            (bx, by, bw, bh),
            existence,
            age,
            hits,
            misses,
            label,
            score,
        ) in columns
    ]


def tracks_to_msg(tracks: TrackSet, header: Header) -> TrackArray:
    return TrackArray(header=header, tracks=tracks_to_msgs(tracks))


def target_to_msg(
    header: Header,
    mode: SelectionPolicy,
    tracks: TrackSet,
    track_id: int | None,
    lead_time: float,
) -> Target:
    """The Target message; locked only when track_id names a track of `tracks`."""
    index = None if track_id is None else tracks.index_of(track_id)
    target = Target(
        header=header, locked=index is not None, selection=int(mode), lead_time=float(lead_time)
    )
    if index is not None:
        target.track = track_to_msg(tracks, index)
        predicted = extrapolate_positions(tracks.means[index], tracks.layout, lead_time)[0]
        target.predicted_x, target.predicted_y = float(predicted[0]), float(predicted[1])
    return target


def _zones_problem(name: str) -> Callable[[Any], str | None]:
    def problem(value: Any) -> str | None:
        try:
            parse_polygons(value, name)
        except ValueError as error:
            return str(error)
        return None

    return problem


@dataclass(frozen=True)
class TrackerNodeConfig:
    """The tracker node's own parameters, beside its method's and the target selection's."""

    scene_frame_id: str = param("scene", "frame of the detections, tracks and target")
    reliable_images: bool = param(
        False, "reliable QoS for needed images (lockstep)", read_only=True
    )
    pairing_capacity: int = param(
        30, "frames waiting for their needed inputs at most", min=1, max=1000
    )
    max_input_gap: float = param(
        2.0,
        "gap between two detection stamps beyond which the input is taken to have stopped (a "
        "live camera that dropped out): the tracks are cleared, not predicted across the gap",
        min=0.01,
        max=86400.0,
        unit="s",
    )
    ignore_zones: str = param(
        "",
        "scene polygons 'x1,y1,x2,y2,x3,y3; ...' where detections are ignored (their box's "
        "bottom centre inside): a flag, a tree, a road ('' = none)",
        unit="px",
        validator=_zones_problem("ignore_zones"),
    )
    required_zones: str = param(
        "",
        "scene polygons as ignore_zones: the camera follows a track only once its box's "
        "bottom centre has been in one (Frigate's required_zones; '' = any track)",
        validator=_zones_problem("required_zones"),
    )

    def problems(self) -> list[str]:
        return []


def zones_of(settings: TrackerNodeConfig) -> Zones:
    return Zones(
        parse_polygons(settings.ignore_zones, "ignore_zones"),
        parse_polygons(settings.required_zones, "required_zones"),
    )


#: The named defaults a method may offer (gated_hungarian: multi, seed000, seed000_kalman).
PRESET_PARAMETER = ParamSpec(
    "preset", "", "named defaults of the method's parameters", read_only=True
)


def parameter_specs(method: Method[Tracker], preset: str) -> list[ParamSpec]:
    """The node's parameters for `method` with `preset`: the method's own, then the target
    selection's and the node's, defaults from the preset."""
    defaults = {**SELECTION_DEFAULTS, **method.defaults(preset)}
    specs = [replace(spec, default=defaults[spec.name]) for spec in method.parameters]
    specs += [replace(spec, default=defaults[spec.name]) for spec in SELECTION_PARAMETERS]
    specs += specs_of(TrackerNodeConfig)
    return specs


class TrackerNode(SuiteNode):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tracker", **kwargs)
        for problem in TRACKERS.load_entry_points(PLUGIN_GROUP):
            self.problems.report("unusable tracker plug-in", problem)
        choice = declare_parameters(
            self,
            [
                TRACKERS.method_spec(),
                PRESET_PARAMETER,
            ],
        )
        self._method = TRACKERS.get(choice["method"])
        preset = choice["preset"] or ("multi" if "multi" in self._method.presets else "")
        try:
            specs = parameter_specs(self._method, preset)
        except ValueError as error:
            raise ParameterError(str(error)) from error
        self._params = declare_parameters(
            self, specs, on_change=self._on_parameters, check_all=self._check_parameters
        )
        self.settings = config_from_params(TrackerNodeConfig, self._params)
        self._selection = config_from_params(SelectionConfig, self._params)
        self._tracker: Tracker = self._build_tracker(first_id=1)
        if self._method.warm_up is not None:
            self._method.warm_up()
        self._selector = self._selection.selector()
        self._epoch_ns: int | None = None  # stamp of the first frame: keeps float seconds exact
        self._view_centre: tuple[float, float] | None = None
        self._last_frame: tuple[int, int | None] = (0, None)  # tracks, followed track id
        self._order = StampOrder(max_gap_ns=self._max_gap_ns())
        self._zones = zones_of(self.settings)
        self.ignored_in_zones = 0  # detections dropped in an ignore zone
        needs = self._tracker.needs
        self._frames = FrameAssembler(
            frozenset(need.value for need in needs), self.settings.pairing_capacity
        )

        self._tracks_pub = self.create_publisher(TrackArray, "tracks", result_qos())
        # the same tracks for consumers of vision_msgs, beside wherever tracks is remapped
        self._vision_pub = self.create_publisher(
            Detection2DArray, self._tracks_pub.topic_name + "_2d", result_qos()
        )
        self._target_pub = self.create_publisher(Target, "target", result_qos())
        self.create_subscription(BlobArray, "detections", self._on_detections, 10)
        self.create_subscription(PtzState, "ptz/state", self._on_ptz_state, 10)
        image_topics = {Need.IMAGE: "camera/image_raw", Need.MASK: "detector/motion_mask"}
        for need, topic in image_topics.items():
            if need in needs:
                self.create_subscription(
                    Image,
                    topic,
                    partial(self._on_image_part, need),
                    image_qos(self.settings.reliable_images),
                )
        # private (~/): two trackers in one graph (the colour graph) must not serve one name
        self.create_service(SelectTarget, "~/select_target", self._on_select_target)
        self.create_service(ResetTracker, "~/reset_tracker", self._on_reset_tracker)
        needed = ", ".join(sorted(n.value for n in needs)) or "detections only"
        kind = self._method_values(self._params).get("filter")  # the method's, if it has one
        self.get_logger().info(
            f"tracker ready: method {self._method.name}"
            + (f", preset {preset}" if preset else "")
            + (f", filter {kind}" if kind is not None else "")
            + f", selection {self._selection.selection_policy}; needs {needed}"
            + self._zones.describe()
        )

    # --- parameters ---------------------------------------------------------------------------

    def _method_values(self, values: dict[str, Any]) -> dict[str, Any]:
        return {spec.name: values[spec.name] for spec in self._method.parameters}

    def _build_tracker(self, first_id: int) -> Tracker:
        return self._method.build(self._method_values(self._params), first_id)

    def _check_parameters(self, values: dict[str, Any]) -> str | None:
        method_values = self._method_values(values)
        reason = self._method.problems(method_values)
        if reason:
            return reason
        try:
            tracker = self._method.build(method_values, 1)
        except ValueError as error:
            return str(error)
        current = getattr(self, "_tracker", None)  # None while the parameters are declared
        if current is not None and tracker.needs != current.needs:
            wanted = ", ".join(sorted(n.value for n in tracker.needs))
            return (
                f"these values need the inputs {{{wanted}}}: the topics a tracker subscribes to "
                "are chosen at start (restart the node with them)"
            )
        return None

    def _max_gap_ns(self) -> int:
        return round(float(self.settings.max_input_gap) * NS_PER_S)

    def _on_parameters(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(TrackerNodeConfig, self._params)
        self._selection = config_from_params(SelectionConfig, self._params)
        self._selection.apply_to(self._selector)
        self._order.max_gap_ns = self._max_gap_ns()
        if {"ignore_zones", "required_zones"} & set(changed):
            self._zones = zones_of(self.settings)
        rebuilt = set(changed) - LIVE_PARAMETERS
        if rebuilt:
            cleared = self._forget_tracks()
            self._tracker = self._build_tracker(first_id=self._tracker.next_id)
            self.get_logger().info(
                f"{', '.join(sorted(rebuilt))} changed: tracker rebuilt, {cleared} track(s) cleared"
            )

    # --- topics -------------------------------------------------------------------------------

    def _on_ptz_state(self, msg: PtzState) -> None:
        try:
            window = msg_to_window(msg.window)
        except ValueError as error:
            self.problems.report(
                "invalid PtzState window", f"ignored a PtzState window for the view centre: {error}"
            )
            return
        self._view_centre = window.center
        if Need.WINDOW in self._tracker.needs:
            self._track(self._frames.add_part("window", stamp_to_ns(msg.header.stamp), window))

    def _on_image_part(self, need: Need, msg: Image) -> None:
        try:
            pixels = image_to_bgr(msg) if need is Need.IMAGE else image_to_array(msg)
        except UnsupportedEncodingError as error:
            self.problems.report(error.cause, f"ignored a {need.value} image: {error}")
            return
        if need is Need.MASK and pixels.ndim != 2:
            self.problems.report("colour motion mask", "ignored a motion mask that is not mono8")
            return
        self._track(self._frames.add_part(need.value, stamp_to_ns(msg.header.stamp), pixels))

    def _on_detections(self, msg: BlobArray) -> None:
        if msg.header.frame_id and msg.header.frame_id != self.settings.scene_frame_id:
            self.problems.report(
                "detections in another frame",
                f"detections are in frame '{msg.header.frame_id}', expected "
                f"'{self.settings.scene_frame_id}'; tracking them as scene pixels",
            )
        stamp_ns = stamp_to_ns(msg.header.stamp)
        received = len(msg.blobs)
        oriented = [blob for blob in msg.blobs if has_usable_orientation(blob)]
        if len(oriented) < received:
            self.problems.report(
                "unusable oriented box",
                "dropped a detection: its angle or oriented size is not finite, beyond "
                f"{MAX_MESSAGE_VALUE:g} or negative",
                len(msg.blobs) - len(oriented),
            )
            msg.blobs = oriented
        detections = detections_from_msg(msg)
        all_corrupt = (received and not oriented) or (
            len(detections) and not len(detections.validated()[0])
        )
        if all_corrupt:
            # refused before its stamp counts (and not answered): it moves no clock
            self.problems.report(
                "no usable detection",
                f"dropped the detections stamped {stamp_ns} ns: none of their {received} "
                "blobs can be a measurement (values not finite or out of range)",
            )
            return
        order = self._order.check(stamp_ns)
        if order in (Order.REPEAT, Order.INVALID):
            self.problems.report(
                f"{order.value} detections stamp",
                f"dropped detections stamped {stamp_ns} ns ({order.value}): each frame is "
                "tracked once",
            )
            return
        if order is Order.NEW_EPOCH:
            self._start_epoch()
        self._track(self._frames.add_primary(stamp_ns, (msg, detections)))

    def _track(self, frames: list[Frame]) -> None:
        """Step the tracker once per released frame and publish its tracks and target."""
        for frame in frames:
            msg, detections = frame.primary  # the BlobArray and its Detections
            if frame.missing:
                self.problems.report(
                    f"no {' and '.join(frame.missing)} for detections",
                    f"tracked the detections stamped {frame.stamp_ns} ns without their "
                    f"{' and '.join(frame.missing)} (not received): a missed frame for the tracker",
                )
            if self._epoch_ns is None:
                self._epoch_ns = frame.stamp_ns
            detections, ignored = self._zones.outside_ignored(detections)
            self.ignored_in_zones += ignored
            tracks = self._tracker.step(
                Observation(
                    time=(frame.stamp_ns - self._epoch_ns) / NS_PER_S,
                    detections=detections,
                    present=bool(msg.target_present),
                    image=frame.parts.get(Need.IMAGE.value),
                    mask=frame.parts.get(Need.MASK.value),
                    window=frame.parts.get(Need.WINDOW.value),
                )
            )
            for cause, count in tracks.rejections.items():
                self.problems.report(cause, f"dropped a detection: {cause}", count)
            header = Header(stamp=msg.header.stamp, frame_id=self.settings.scene_frame_id)
            self._publish(header, tracks)

    def _forget_tracks(self, reset_ids: bool = False) -> int:
        """Clear the tracks, the selection and the time base; how many tracks there were."""
        self._track(self._frames.clear())  # frames still waiting are answered on the old base
        cleared = self._tracker.reset(reset_ids=reset_ids)
        self._selector.reset()
        self._zones.reset()
        self._epoch_ns = None
        return cleared

    def _start_epoch(self) -> None:
        """Time jumped back (a restarted or looping source) or leapt past `max_input_gap` (an
        input that stopped): the tracks of the old time base go."""
        cleared = self._forget_tracks()
        self.get_logger().info(
            f"detections: {self._order.describe_jump()}; a new epoch: {cleared} track(s) "
            f"cleared, ids continue from {self._tracker.next_id}"
        )

    def _publish(self, header: Header, tracks: TrackSet) -> None:
        """One TrackArray and one Target per input frame (lockstep), even without tracks."""
        allowed = self._zones.followable(tracks)
        selection = self._selector.update(tracks, self._view_centre, allowed)  # None: no target
        tracks_msg = tracks_to_msg(tracks, header)
        self._tracks_pub.publish(tracks_msg)
        if self._vision_pub.get_subscription_count():
            self._vision_pub.publish(tracks_to_vision(tracks_msg))
        track_id = selection.track_id if selection is not None else None
        self._last_frame = (len(tracks), track_id)
        mode = selection.mode if selection is not None else self._selector.mode
        self._target_pub.publish(
            target_to_msg(header, mode, tracks, track_id, self._selection.lead_time)
        )

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        tracks, followed = self._last_frame
        state = "searching" if followed is None else f"tracking track {followed}"
        details = {"method": self._method.name, "tracks": str(tracks)}
        if self._zones.ignore:
            details["detections in ignore zones"] = str(self.ignored_in_zones)
        if self._zones.required:
            details["tracks seen in a required zone"] = str(len(self._zones.entered))
        return state, details

    # --- services -----------------------------------------------------------------------------

    def _on_select_target(
        self, request: SelectTarget.Request, response: SelectTarget.Response
    ) -> SelectTarget.Response:
        if request.mode == SelectTarget.Request.MODE_AUTO:
            result = self._selector.select_auto()
        elif request.mode == SelectTarget.Request.MODE_TRACK_ID:
            result = self._selector.select_id(int(request.track_id))
        elif request.mode == SelectTarget.Request.MODE_RECTANGLE:
            try:
                result = self._selector.select_rectangle(msg_to_rect(request.rectangle))
            except ValueError as error:
                response.success, response.message = False, str(error)
                return response
        else:
            response.success, response.message = False, f"unknown mode {request.mode}"
            return response
        response.success, response.message = result.success, result.message
        response.selected_track_id = result.track_id or 0
        self.get_logger().info(f"select_target: {result.message}")
        return response

    def _on_reset_tracker(
        self, request: ResetTracker.Request, response: ResetTracker.Response
    ) -> ResetTracker.Response:
        response.tracks_cleared = self._forget_tracks(reset_ids=request.reset_ids)
        self._order.reset()
        response.success = True
        response.message = f"cleared {response.tracks_cleared} track(s)" + (
            "; ids restart at 1" if request.reset_ids else ""
        )
        self.get_logger().info(f"reset_tracker: {response.message}")
        return response


def main(args: list[str] | None = None) -> int:
    return run_node(TrackerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
