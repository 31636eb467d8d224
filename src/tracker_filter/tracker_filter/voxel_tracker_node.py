"""voxel_tracker node: seed 002's per-person particle filters on an occupancy volume.

Subscribes `occupancy` (sensor_msgs/PointCloud2: the occupied voxel centres, metres, REP-103,
z up; the contract is in `voxel_tracking`), publishes `tracks` (tracker_msgs/TrackArray, state
layout "x y z", metres, in the cloud's frame). The tracking is in `occupancy_particles`; this
file declares parameters, converts messages and wires topics.
"""

from __future__ import annotations

from typing import Any

from sensor_msgs.msg import PointCloud2

from tracker_filter.occupancy_particles import (
    Jitter,
    OccupancyFilterConfig,
    OccupancyParticleFilters,
    Propagation,
)
from tracker_filter.voxel_tracking import (
    LAYOUT_TEXT,
    CloudError,
    Track3D,
    VoxelTracker,
    cloud_points,
    exclusion_mask,
    room_geometry,
)
from tracker_msgs.msg import Rect, Track, TrackArray
from tracker_msgs_py.codec import NS_PER_S, float64_sequence, image_qos, result_qos, stamp_to_ns
from tracker_msgs_py.node_main import StartupError, SuiteNode, run_node
from tracker_msgs_py.params import ParameterError, ParamSpec, declare_parameters

_C = OccupancyFilterConfig()
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("room_min", [0.0, 0.0, 0.0], "m: the room's corner (x, y, z; z = the floor)"),
    ParamSpec("room_max", [4.0, 5.0, 2.1], "m: the opposite corner (the thesis's room)"),
    ParamSpec(
        "exclusion_boxes",
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        "m: boxes forced to background (doors), x0 y0 z0 x1 y1 z1 each (the default is empty)",
    ),
    ParamSpec("voxel_size", 0.02, "m: voxel edge of the incoming volume", 0.001, 1.0),
    ParamSpec("particles", _C.particles, "particles per person (the thesis: 300)", 1, 100000),
    ParamSpec("blocking", _C.blocking, "no particle inside another person's ellipsoid"),
    ParamSpec(
        "foreground_factor",
        _C.foreground_factor,
        "likelihood x the foreground share n1 / 27 (thesis: off)",
    ),
    ParamSpec(
        "propagation",
        _C.propagation.value,
        "a taken voxel: the nearest free one, or the nearest free foreground one",
        choices=tuple(p.value for p in Propagation),
    ),
    ParamSpec(
        "jitter",
        _C.jitter.value,
        "resampling jitter: room / N^(1/3) (vertical doubled), or the expanded rule",
        choices=tuple(j.value for j in Jitter),
    ),
    ParamSpec("opening", _C.opening, "vertical opening, voxels (1: off)", 1, 100),
    ParamSpec("min_blob", _C.min_blob, "voxels x voxel edge (m) a person's blob exceeds", 0.0, 1e6),
    ParamSpec("min_height", _C.min_height, "m a person's blob spans vertically", 0.0, 10.0),
    ParamSpec(
        "exclusion", _C.exclusion, "m on the floor: no new filter nearer a filter", 0.0, 10.0
    ),
    ParamSpec(
        "starve_weight", _C.starve_weight, "mean weight below which a frame starves", 0.0, 1.0
    ),
    ParamSpec("starve_frames", _C.starve_frames, "starved frames before deletion", 1, 10000),
    ParamSpec("confirm_frames", 3, "frames a new filter is tentative at least", 0, 10000),
    ParamSpec(
        "confirm_travel",
        0.3,
        "m on the floor a filter must once have moved from its start to be a person (furniture "
        "never walks)",
        0.0,
        100.0,
    ),
    ParamSpec("seed", _C.seed, "random seed (a replay gives the same tracks)", 0, 2**31 - 1),
    ParamSpec("reliable_input", False, "reliable QoS for the clouds (replays)", read_only=True),
)


def build_tracker(values: dict[str, Any]) -> VoxelTracker:
    """The tracker the parameter values describe; ValueError when they do not make a room."""
    geometry = room_geometry(values["room_min"], values["room_max"], values["voxel_size"])
    config = OccupancyFilterConfig(
        particles=values["particles"],
        blocking=values["blocking"],
        foreground_factor=values["foreground_factor"],
        propagation=Propagation(values["propagation"]),
        jitter=Jitter(values["jitter"]),
        opening=values["opening"],
        min_blob=values["min_blob"],
        min_height=values["min_height"],
        exclusion=values["exclusion"],
        starve_weight=values["starve_weight"],
        starve_frames=values["starve_frames"],
        seed=values["seed"],
    )
    return VoxelTracker(
        OccupancyParticleFilters(config, exclusion_mask(geometry, values["exclusion_boxes"])),
        geometry,
        values["confirm_frames"],
        values["confirm_travel"],
    )


def track_to_msg(track: Track3D) -> Track:
    x, y, z = (float(v) for v in track.mean)
    fx, fy, fw, fd = (float(v) if v == v else 0.0 for v in track.footprint)
    return Track(
        id=track.id,
        status=int(track.status),
        x=x,
        y=y,
        position_covariance=track.covariance[:2, :2].reshape(-1).tolist(),
        state_layout=LAYOUT_TEXT,
        state=float64_sequence(track.mean),
        covariance=float64_sequence(track.covariance),
        bbox=Rect(x=fx, y=fy, width=fw, height=fd),
        existence=track.existence,
        age=float(track.age),
        hits=track.hits,
        consecutive_misses=track.consecutive_misses,
    )


class VoxelTrackerNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("voxel_tracker", **node_options)
        try:
            self.values = declare_parameters(self, PARAMETERS, on_change=self._on_parameters)
            self.tracker = build_tracker(self.values)
        except (ParameterError, ValueError) as error:
            raise StartupError(str(error)) from error
        self._tracks_pub = self.create_publisher(TrackArray, "tracks", result_qos())
        reliable = self.values["reliable_input"]
        self.create_subscription(PointCloud2, "occupancy", self._on_cloud, image_qos(reliable))
        geometry = self.tracker.geometry
        self.get_logger().info(
            f"voxel_tracker: grid {geometry.shape} of {geometry.cell[0]} m, "
            f"{self.values['particles']} particles per person"
        )

    def _on_parameters(self, changed: dict[str, Any]) -> None:
        values = self.values | changed
        try:
            self.tracker = build_tracker(values)
        except ValueError as error:
            self.problems.report("unusable parameters", str(error))
            return
        self.values = values
        self.get_logger().info(f"parameters changed ({', '.join(changed)}): tracks cleared")

    def _on_cloud(self, msg: PointCloud2) -> None:
        fields = {f.name: (int(f.offset), int(f.datatype)) for f in msg.fields}
        try:
            points = cloud_points(
                fields, msg.point_step, bytes(msg.data), msg.width * msg.height, msg.is_bigendian
            )
            tracks, dropped = self.tracker.step(points, stamp_to_ns(msg.header.stamp) / NS_PER_S)
        except (CloudError, ValueError) as error:
            self.problems.report("unusable occupancy cloud", str(error))
            return
        if dropped:
            self.problems.report("points outside the room", f"{dropped} point(s) dropped")
        out = TrackArray(header=msg.header, tracks=[track_to_msg(t) for t in tracks])
        self._tracks_pub.publish(out)


def main(args: list[str] | None = None) -> int:
    return run_node(VoxelTrackerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
