"""voxel_tracker node: seed 002's per-person particle filters on an occupancy volume.

Subscribes `occupancy` (sensor_msgs/PointCloud2: the occupied voxel centres, metres, REP-103,
z up; the contract is in `voxel_tracking`), publishes `tracks` (tracker_msgs/TrackArray, state
layout "x y z", metres, in the cloud's frame). The tracking is in `occupancy_particles`; this
file declares parameters, converts messages and wires topics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sensor_msgs.msg import PointCloud2

from tracker_filter.occupancy.occupancy_particles import (
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
from tracker_msgs_py.params import (
    ParameterError,
    ParamSpec,
    config_from_params,
    declare_parameters,
    param,
    specs_of,
)

_C = OccupancyFilterConfig()


@dataclass(frozen=True)
class VoxelTrackerNodeConfig:
    """The voxel tracker node's parameters: the room, the filters' (`OccupancyFilterConfig`) and
    the confirmation rules."""

    room_min: tuple[float, ...] = param(
        [0.0, 0.0, 0.0], "the room's corner (x, y, z; z = the floor)", unit="m"
    )
    room_max: tuple[float, ...] = param(
        [4.0, 5.0, 2.1], "the opposite corner (the thesis's room)", unit="m"
    )
    exclusion_boxes: tuple[float, ...] = param(
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        "boxes forced to background (doors), x0 y0 z0 x1 y1 z1 each (the default is empty)",
        unit="m",
    )
    voxel_size: float = param(
        0.02, "voxel edge of the incoming volume", min=0.001, max=1.0, unit="m"
    )
    particles: int = param(
        _C.particles, "particles per person (the thesis: 300)", min=1, max=100000
    )
    blocking: bool = param(_C.blocking, "no particle inside another person's ellipsoid")
    foreground_factor: bool = param(
        _C.foreground_factor, "likelihood x the foreground share n1 / 27 (thesis: off)"
    )
    propagation: str = param(
        _C.propagation.value,
        "a taken voxel: the nearest free one, or the nearest free foreground one",
        choices=tuple(p.value for p in Propagation),
    )
    jitter: str = param(
        _C.jitter.value,
        "resampling jitter: room / N^(1/3) (vertical doubled), or the expanded rule",
        choices=tuple(j.value for j in Jitter),
    )
    opening: int = param(_C.opening, "vertical opening, voxels (1: off)", min=1, max=100)
    min_blob: float = param(
        _C.min_blob, "voxels x voxel edge (m) a person's blob exceeds", min=0.0, max=1e6
    )
    min_height: float = param(
        _C.min_height, "height a person's blob spans", min=0.0, max=10.0, unit="m"
    )
    exclusion: float = param(
        _C.exclusion,
        "no new filter nearer a filter than this, on the floor",
        min=0.0,
        max=10.0,
        unit="m",
    )
    starve_weight: float = param(
        _C.starve_weight, "mean weight below which a frame starves", min=0.0, max=1.0
    )
    starve_frames: int = param(_C.starve_frames, "starved frames before deletion", min=1, max=10000)
    confirm_frames: int = param(3, "frames a new filter is tentative at least", min=0, max=10000)
    confirm_travel: float = param(
        0.3,
        "distance on the floor a filter must once have moved from its start to be a person "
        "(furniture never walks)",
        min=0.0,
        max=100.0,
        unit="m",
    )
    seed: int = param(_C.seed, "random seed (a replay gives the same tracks)", min=0, max=2**31 - 1)
    reliable_input: bool = param(False, "reliable QoS for the clouds (replays)", read_only=True)

    def problems(self) -> list[str]:
        return []

    def filter_config(self) -> OccupancyFilterConfig:
        return OccupancyFilterConfig(
            particles=self.particles,
            blocking=self.blocking,
            foreground_factor=self.foreground_factor,
            propagation=Propagation(self.propagation),
            jitter=Jitter(self.jitter),
            opening=self.opening,
            min_blob=self.min_blob,
            min_height=self.min_height,
            exclusion=self.exclusion,
            starve_weight=self.starve_weight,
            starve_frames=self.starve_frames,
            seed=self.seed,
        )


PARAMETERS: tuple[ParamSpec, ...] = specs_of(VoxelTrackerNodeConfig)


def build_tracker(config: VoxelTrackerNodeConfig) -> VoxelTracker:
    """The tracker `config` describes; ValueError when it does not make a room."""
    geometry = room_geometry(list(config.room_min), list(config.room_max), config.voxel_size)
    return VoxelTracker(
        OccupancyParticleFilters(
            config.filter_config(), exclusion_mask(geometry, list(config.exclusion_boxes))
        ),
        geometry,
        config.confirm_frames,
        config.confirm_travel,
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
            self.settings = config_from_params(VoxelTrackerNodeConfig, self.values)
            self.tracker = build_tracker(self.settings)
        except (ParameterError, ValueError) as error:
            raise StartupError(str(error)) from error
        self._tracks_pub = self.create_publisher(TrackArray, "tracks", result_qos())
        reliable = self.settings.reliable_input
        self.create_subscription(PointCloud2, "occupancy", self._on_cloud, image_qos(reliable))
        geometry = self.tracker.geometry
        self.get_logger().info(
            f"voxel_tracker: grid {geometry.shape} of {geometry.cell[0]} m, "
            f"{self.settings.particles} particles per person"
        )

    def _on_parameters(self, changed: dict[str, Any]) -> None:
        values = self.values | changed
        try:
            settings = config_from_params(VoxelTrackerNodeConfig, values)
            self.tracker = build_tracker(settings)
        except ValueError as error:
            self.problems.report("unusable parameters", str(error))
            return
        self.values, self.settings = values, settings
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
