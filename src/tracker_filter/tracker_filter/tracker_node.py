"""tracker node: detections in, tracks and the pan-tilt target out, one of each per BlobArray.

Subscribes detections (tracker_msgs/BlobArray, scene frame) and ptz/state (tracker_msgs/PtzState,
for the view centre); publishes tracks (tracker_msgs/TrackArray) and target (tracker_msgs/Target)
stamped with the BlobArray's stamp; serves select_target and reset_tracker. All the tracking is in
the core modules; this file declares parameters, converts messages and wires topics.
"""

from __future__ import annotations

import array
from typing import Any

import numpy as np
from std_msgs.msg import Header

from tracker_filter.config import LIVE_PARAMETERS, PARAMETERS, PRESETS, TrackerConfig
from tracker_filter.management import Detections, MultiTargetTracker, TrackSet
from tracker_filter.models import extrapolate_positions
from tracker_filter.selection import SelectionPolicy, TargetSelector
from tracker_msgs.msg import BlobArray, PtzState, Rect, Target, Track, TrackArray
from tracker_msgs.srv import ResetTracker, SelectTarget
from tracker_msgs_py.codec import msg_to_rect, msg_to_window, stamp_to_ns
from tracker_msgs_py.node_main import SuiteNode, run_node
from tracker_msgs_py.params import ParamSpec, declare_parameters
from tracker_msgs_py.stamps import Order, StampOrder

NS_PER_S = 1e9


def detections_from_msg(msg: BlobArray) -> Detections:
    """The BlobArray's blobs as Detections; none when the detector's presence test failed."""
    if not msg.target_present or not msg.blobs:
        return Detections.empty()
    blobs = msg.blobs
    return Detections(
        positions=np.array([(b.centroid_x, b.centroid_y) for b in blobs], dtype=float),
        areas=np.array([b.area for b in blobs], dtype=float),
        bboxes=np.array(
            [(b.bbox.x, b.bbox.y, b.bbox.width, b.bbox.height) for b in blobs], dtype=float
        ),
        scores=np.array([b.score for b in blobs], dtype=float),
    )


def _float64_sequence(values: np.ndarray) -> array.array:
    """A float64[] field value; array.array skips rclpy's per-element checks of a list."""
    sequence = array.array("d")
    sequence.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return sequence


def track_to_msg(tracks: TrackSet, i: int) -> Track:
    mean, covariance = tracks.means[i], tracks.covariances[i]
    x, y, vx, vy = (float(v) for v in mean[:4])
    bx, by, bw, bh = (float(v) for v in tracks.bboxes[i])
    return Track(
        id=int(tracks.ids[i]),
        status=int(tracks.status[i]),
        x=x,
        y=y,
        vx=vx,
        vy=vy,
        position_covariance=covariance[:2, :2].reshape(-1),
        state_layout=" ".join(tracks.state_layout),
        state=_float64_sequence(mean),
        covariance=_float64_sequence(covariance),
        bbox=Rect(x=bx, y=by, width=max(bw, 0.0), height=max(bh, 0.0)),
        existence=float(tracks.existence[i]),
        age=float(tracks.ages[i]),
        hits=int(tracks.hits[i]),
        consecutive_misses=int(tracks.misses[i]),
    )


def tracks_to_msg(tracks: TrackSet, header: Header) -> TrackArray:
    return TrackArray(header=header, tracks=[track_to_msg(tracks, i) for i in range(len(tracks))])


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
        predicted = extrapolate_positions(tracks.means[index], tracks.state_layout, lead_time)[0]
        target.predicted_x, target.predicted_y = float(predicted[0]), float(predicted[1])
    return target


def _parameter_specs(preset: str) -> list[ParamSpec]:
    defaults = PRESETS[preset]
    specs = [
        ParamSpec(
            info.name, defaults[info.name], info.description, info.min, info.max, info.choices
        )
        for info in PARAMETERS
    ]
    specs.append(
        ParamSpec(
            "scene_frame_id", "scene", "frame of the detections, tracks and target (the scene)"
        )
    )
    return specs


class TrackerNode(SuiteNode):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("tracker", **kwargs)
        preset_spec = ParamSpec(
            "preset",
            "multi",
            "named defaults of the other parameters",
            choices=tuple(PRESETS),
            read_only=True,
        )
        preset = declare_parameters(self, [preset_spec])["preset"]
        self._params = declare_parameters(
            self,
            _parameter_specs(preset),
            on_change=self._on_parameters,
            check_all=self._check_parameters,
        )
        self._config = TrackerConfig.from_params(self._params)
        self._tracker: MultiTargetTracker = self._config.build_tracker()
        self._selector: TargetSelector = self._config.build_selector()
        self._epoch_ns: int | None = None  # stamp of the first frame: keeps float seconds exact
        self._view_centre: tuple[float, float] | None = None
        self._order = StampOrder()

        self._tracks_pub = self.create_publisher(TrackArray, "tracks", 10)
        self._target_pub = self.create_publisher(Target, "target", 10)
        self.create_subscription(BlobArray, "detections", self._on_detections, 10)
        self.create_subscription(PtzState, "ptz/state", self._on_ptz_state, 10)
        self.create_service(SelectTarget, "select_target", self._on_select_target)
        self.create_service(ResetTracker, "reset_tracker", self._on_reset_tracker)
        params = self._params
        self.get_logger().info(
            f"tracker ready: preset {preset}, filter {params['filter']}, "
            f"selection {params['selection_policy']}"
        )

    # --- parameters ---------------------------------------------------------------------------

    @staticmethod
    def _check_parameters(values: dict[str, Any]) -> str | None:
        try:
            TrackerConfig.from_params(values)
        except ValueError as error:
            return str(error)
        return None

    def _on_parameters(self, changed: dict[str, Any]) -> None:
        self._config = TrackerConfig.from_params(self._params)
        config = self._config
        self._selector.configure(
            config.selection_policy, config.min_lock_time, config.switch_margin
        )
        rebuilt = set(changed) - LIVE_PARAMETERS - {"scene_frame_id"}
        if rebuilt:
            cleared = self._forget_tracks()
            self._tracker = config.build_tracker(first_id=self._tracker.next_id)
            self.get_logger().info(
                f"{', '.join(sorted(rebuilt))} changed: tracker rebuilt, {cleared} track(s) cleared"
            )

    # --- topics -------------------------------------------------------------------------------

    def _on_ptz_state(self, msg: PtzState) -> None:
        try:
            self._view_centre = msg_to_window(msg.window).center
        except ValueError as error:
            self.problems.report(
                "invalid PtzState window", f"ignored a PtzState window for the view centre: {error}"
            )

    def _on_detections(self, msg: BlobArray) -> None:
        header = Header(stamp=msg.header.stamp, frame_id=self._params["scene_frame_id"])
        if msg.header.frame_id and msg.header.frame_id != header.frame_id:
            self.problems.report(
                "detections in another frame",
                f"detections are in frame '{msg.header.frame_id}', expected "
                f"'{header.frame_id}'; tracking them as scene pixels",
            )
        stamp_ns = stamp_to_ns(msg.header.stamp)
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
        if self._epoch_ns is None:
            self._epoch_ns = stamp_ns
        tracks = self._tracker.step(
            (stamp_ns - self._epoch_ns) / NS_PER_S, detections_from_msg(msg)
        )
        for cause, count in tracks.rejections.items():
            self.problems.report(cause, f"dropped a detection: {cause}", count)
        self._publish(header, tracks)

    def _forget_tracks(self, reset_ids: bool = False) -> int:
        """Clear the tracks, the selection and the time base; how many tracks there were."""
        cleared = self._tracker.reset(reset_ids=reset_ids)
        self._selector.reset()
        self._epoch_ns = None
        return cleared

    def _start_epoch(self) -> None:
        """Time jumped back (a restarted or looping source): the tracks of the old time base go."""
        cleared = self._forget_tracks()
        self.get_logger().info(
            f"detections: {self._order.describe_jump()}; a new replay epoch: {cleared} track(s) "
            f"cleared, ids continue from {self._tracker.next_id}"
        )

    def _publish(self, header: Header, tracks: TrackSet) -> None:
        """One TrackArray and one Target per input frame (lockstep), even without tracks."""
        selection = self._selector.update(tracks, self._view_centre)  # None: nothing to follow
        self._tracks_pub.publish(tracks_to_msg(tracks, header))
        track_id = selection.track_id if selection is not None else None
        mode = selection.mode if selection is not None else self._selector.mode
        self._target_pub.publish(
            target_to_msg(header, mode, tracks, track_id, self._params["lead_time"])
        )

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
