"""Seed 002 in 3-D: occupancy volumes as point clouds in, 3-D tracks out (no rclpy).

The message contract of the `voxel_tracker` node, in plain data so it is testable without ROS:

- input, sensor_msgs/PointCloud2 on `occupancy`: one point per occupied voxel, its centre in
  metres, in a REP-103 frame with z up (the floor at the room's z_min), fields `x`, `y`, `z`
  FLOAT32 or FLOAT64 at any offsets (other fields ignored), any point_step, either byte order;
  `header.stamp` is the frame's time and must increase. Points outside the room or NaN are
  dropped (counted, one log line). A multi-camera reconstruction (visual hull, space carving)
  publishes exactly its foreground voxels.
- the room: `room_min` / `room_max` (metres) and `voxel_size` fix the grid; a point belongs to the
  voxel floor((p - room_min) / voxel_size); `exclusion_boxes` (the doors) are forced to background.
- output: tracker_msgs/TrackArray in the cloud's frame, a Track per filter with state_layout
  "x y z" (metres), x / y the floor position, covariance 3 x 3 of the particles, bbox the
  person's footprint (metres), existence the filter's mean surface weight, and statuses as every
  tracker: TENTATIVE for its first `confirm_frames` frames and until its estimate has once been
  `confirm_travel` m from where it started (`reported_filters`), then CONFIRMED when the filter
  found its person's surface this frame, COASTING when not, LOST once when it is deleted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tracker_filter.occupancy.occupancy_grid import GridGeometry, OccupancyGrid
from tracker_filter.occupancy.occupancy_particles import FilterStep, OccupancyParticleFilters
from tracker_filter.tracking import TrackStatus

LAYOUT_TEXT = "x y z"
FLOAT_TYPES = {7: "f4", 8: "f8"}  # sensor_msgs/PointField FLOAT32, FLOAT64


def reported_filters(step: FilterStep, confirm_frames: int, confirm_travel: float) -> np.ndarray:
    """Which filters of a step are people: alive, `confirm_frames` old, and once at least
    `confirm_travel` m (on the floor) from where they started -- furniture, a jacket or a blob
    of noise never walks, a person does at least once (the thesis reports every filter: chairs
    and a jacket were most of its false positives)."""
    result: np.ndarray = (
        ~step.deleted & (step.frames >= confirm_frames) & (step.travel >= confirm_travel)
    )
    return result


class CloudError(ValueError):
    """A point cloud this tracker cannot read (the message names the cause)."""


def cloud_points(
    fields: dict[str, tuple[int, int]],
    point_step: int,
    data: bytes,
    count: int,
    big_endian: bool = False,
) -> np.ndarray:
    """The (P, 3) float64 x, y, z of a PointCloud2's points; `fields` maps a field name to its
    (offset, datatype). Raises CloudError when x, y or z is missing or not a float type."""
    missing = [name for name in "xyz" if name not in fields]
    if missing:
        raise CloudError(f"point cloud without field(s) {', '.join(missing)}")
    order = ">" if big_endian else "<"
    formats = {}
    for name in "xyz":
        offset, datatype = fields[name]
        if datatype not in FLOAT_TYPES:
            raise CloudError(f"point cloud field {name} has datatype {datatype}, not a float")
        formats[name] = (order + FLOAT_TYPES[datatype], offset)
    if point_step <= 0 or len(data) < count * point_step:
        raise CloudError(f"point cloud of {len(data)} bytes for {count} points of {point_step}")
    dtype = np.dtype(
        {
            "names": list("xyz"),
            "formats": [formats[n][0] for n in "xyz"],
            "offsets": [formats[n][1] for n in "xyz"],
            "itemsize": point_step,
        }
    )
    records = np.frombuffer(data, dtype=dtype, count=count)
    return np.column_stack([records[n].astype(np.float64) for n in "xyz"])


def room_geometry(room_min: list[float], room_max: list[float], voxel: float) -> GridGeometry:
    """The grid of the room [room_min, room_max] (metres) at `voxel` m; z is the vertical."""
    low, high = np.asarray(room_min, float), np.asarray(room_max, float)
    if low.shape != (3,) or high.shape != (3,) or not (high > low).all() or voxel <= 0:
        raise ValueError(f"room {room_min} .. {room_max} at {voxel} m is not a box")
    shape = np.ceil((high - low) / voxel - 1e-9).astype(int)
    return GridGeometry(
        (int(shape[0]), int(shape[1]), int(shape[2])), (voxel,) * 3, tuple(low.tolist()), 2
    )


def exclusion_mask(geometry: GridGeometry, boxes: list[float]) -> np.ndarray | None:
    """The door mask: True on every voxel whose centre lies in one of `boxes`, given as
    x0 y0 z0 x1 y1 z1 metres each (a box of no volume excludes nothing); None when none does.
    Raises ValueError when the numbers are not whole boxes."""
    values = np.asarray(boxes, dtype=float)
    if values.size % 6:
        raise ValueError(
            f"exclusion boxes take 6 numbers each (x0 y0 z0 x1 y1 z1), got {values.size}"
        )
    axes = [
        geometry.origin[a] + (np.arange(geometry.shape[a]) + 0.5) * geometry.cell[a]
        for a in range(3)
    ]
    mask = np.zeros(geometry.shape, dtype=bool)
    for low, high in values.reshape(-1, 2, 3):
        inside = [(axes[a] >= low[a]) & (axes[a] <= high[a]) for a in range(3)]
        mask |= inside[0][:, None, None] & inside[1][None, :, None] & inside[2][None, None, :]
    return mask if mask.any() else None


@dataclass
class Track3D:
    """One reported filter of a frame."""

    id: int
    status: TrackStatus
    mean: np.ndarray  # x, y, z m
    covariance: np.ndarray  # 3 x 3 m^2
    footprint: tuple[float, float, float, float]  # x, y, width, depth m (NaN: no blob)
    existence: float
    age: float  # s
    hits: int
    consecutive_misses: int


@dataclass
class VoxelTracker:
    """The filters plus the per-track counts every Track carries."""

    filters: OccupancyParticleFilters
    geometry: GridGeometry
    confirm_frames: int = 3
    confirm_travel: float = 0.3
    born: dict[int, float] = field(default_factory=dict)
    hits: dict[int, int] = field(default_factory=dict)
    misses: dict[int, int] = field(default_factory=dict)
    last_time: float | None = None

    def step(self, points: np.ndarray, t: float) -> tuple[list[Track3D], int]:
        """Track one frame of occupied voxel centres (P, 3) m at time t s; the tracks, and how
        many points lay outside the room or were not finite."""
        if self.last_time is not None and t <= self.last_time:
            raise ValueError(f"stamp {t:.6f} s is not after the previous {self.last_time:.6f} s")
        geometry = self.geometry
        finite = np.isfinite(points).all(axis=1)
        cells = geometry.indices(points[finite])
        inside = ((cells >= 0) & (cells < np.asarray(geometry.shape))).all(axis=1)
        result = self.filters.step(OccupancyGrid.from_cells(geometry, cells[inside]))
        self.last_time = t
        return self._tracks(result, t), int(len(points) - inside.sum())

    def _tracks(self, result: FilterStep, t: float) -> list[Track3D]:
        tracks = []
        confirmed = reported_filters(result, self.confirm_frames, self.confirm_travel)
        for row, track_id in enumerate(result.ids.tolist()):
            self.born.setdefault(track_id, t)
            measured = bool(result.measured[row])
            self.hits[track_id] = self.hits.get(track_id, 0) + measured
            self.misses[track_id] = 0 if measured else self.misses.get(track_id, 0) + 1
            if result.deleted[row]:
                status = TrackStatus.LOST
            elif not confirmed[row]:
                status = TrackStatus.TENTATIVE
            else:
                status = TrackStatus.CONFIRMED if measured else TrackStatus.COASTING
            low, high = result.lows[row], result.highs[row]
            tracks.append(
                Track3D(
                    id=track_id,
                    status=status,
                    mean=result.estimates[row],
                    covariance=result.covariances[row],
                    footprint=(low[0], low[1], high[0] - low[0], high[1] - low[1]),
                    existence=float(min(1.0, result.mass[row])),
                    age=t - self.born[track_id],
                    hits=self.hits[track_id],
                    consecutive_misses=self.misses[track_id],
                )
            )
            if result.deleted[row]:
                for counts in (self.born, self.hits, self.misses):
                    counts.pop(track_id, None)
        return tracks
