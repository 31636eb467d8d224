"""The voxel_tracker node: occupied voxel centres as PointCloud2 in, 3-D tracks out; the cloud
contract (fields at any offset, float32 or float64, either byte order) and bad clouds."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tracker_filter.occupancy.occupancy_particles import (
    OccupancyFilterConfig,
    OccupancyParticleFilters,
)
from tracker_filter.voxel_tracking import (
    CloudError,
    VoxelTracker,
    cloud_points,
    exclusion_mask,
    room_geometry,
)

rclpy = pytest.importorskip("rclpy")

from node_harness import NodeHarness  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sensor_msgs.msg import PointCloud2, PointField  # noqa: E402
from std_msgs.msg import Header  # noqa: E402

from tracker_filter.voxel_tracker_node import VoxelTrackerNode  # noqa: E402
from tracker_msgs.msg import Track, TrackArray  # noqa: E402

VOXEL = 0.04


def person(x: float, y: float) -> np.ndarray:
    """Voxel centres (P, 3) m of a 1.7 m upright cylinder of radius 0.2 m at x, y."""
    xs = np.arange(VOXEL / 2, 4.0, VOXEL)
    ys = np.arange(VOXEL / 2, 5.0, VOXEL)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    foot = np.column_stack([gx.ravel(), gy.ravel()])
    foot = foot[np.hypot(foot[:, 0] - x, foot[:, 1] - y) <= 0.2]
    zs = np.arange(VOXEL / 2, 1.7, VOXEL)
    return np.array([(fx, fy, z) for z in zs for fx, fy in foot])


def cloud(points: np.ndarray, k: int, dtype: str = "<f4", pad: int = 4) -> PointCloud2:
    size = np.dtype(dtype).itemsize
    step = 3 * size + pad
    record = np.zeros(
        len(points),
        np.dtype(
            {
                "names": list("xyz"),
                "formats": [dtype] * 3,
                "offsets": [0, size, 2 * size],
                "itemsize": step,
            }
        ),
    )
    for axis, name in enumerate("xyz"):
        record[name] = points[:, axis]
    datatype = PointField.FLOAT32 if size == 4 else PointField.FLOAT64
    return PointCloud2(
        header=Header(frame_id="room", stamp=rclpy.time.Time(nanoseconds=k * 40_000_000).to_msg()),
        height=1, width=len(points),
        fields=[PointField(name=n, offset=i * size, datatype=datatype, count=1)
                for i, n in enumerate("xyz")],
        is_bigendian=dtype.startswith(">"), point_step=step, row_step=step * len(points),
        data=record.tobytes(), is_dense=True,
    )  # fmt: skip


@pytest.mark.parametrize("dtype", ["<f4", ">f8"])
def test_clouds_are_read_at_their_offsets_in_their_type_and_byte_order(dtype):
    points = np.array([[0.5, 1.25, 2.0], [3.0, 0.25, 0.5]])
    msg = cloud(points, 0, dtype)
    fields = {f.name: (f.offset, f.datatype) for f in msg.fields}
    read = cloud_points(fields, msg.point_step, bytes(msg.data), 2, msg.is_bigendian)
    assert read == pytest.approx(points)


def test_a_cloud_without_z_or_with_integer_fields_is_refused_by_name():
    with pytest.raises(CloudError, match="field"):
        cloud_points({"x": (0, 7), "y": (4, 7)}, 12, bytes(12), 1)
    with pytest.raises(CloudError, match="datatype 5"):
        cloud_points({"x": (0, 5), "y": (4, 7), "z": (8, 7)}, 12, bytes(12), 1)


def test_a_person_in_the_door_box_never_starts_a_filter():
    room = room_geometry([0.0, 0.0, 0.0], [4.0, 5.0, 2.1], VOXEL)
    door = exclusion_mask(room, [0.5, 0.5, 0.0, 1.5, 1.5, 2.1])
    tracker = VoxelTracker(OccupancyParticleFilters(OccupancyFilterConfig(), door), room)
    tracks, _ = tracker.step(np.concatenate([person(1.0, 1.0), person(3.0, 3.0)]), 0.0)
    assert [round(float(t.mean[0]), 1) for t in tracks] == [3.0]  # only the one outside
    assert exclusion_mask(room, [0.0] * 6) is None  # the parameter's default: no door
    with pytest.raises(ValueError, match="6 numbers"):
        exclusion_mask(room, [0.0, 1.0])


@pytest.mark.ros
def test_the_node_tracks_two_people_in_the_room_frame_and_survives_a_bad_cloud():
    h = NodeHarness(
        VoxelTrackerNode,
        inputs={"occupancy": (PointCloud2, 10)},
        outputs={"tracks": (TrackArray, 50)},
        voxel_size=VOXEL,
        reliable_input=True,
    )
    try:
        bad = cloud(person(1.0, 1.0), 0)
        bad.fields = bad.fields[:2]
        h.publish("occupancy", bad)  # no z: one log line, no output, the node goes on
        for k in range(1, 16):  # both walk 0.45 m: people (a chair never moves)
            both = np.concatenate([person(1.0 + 0.03 * k, 1.0), person(3.0, 4.0 - 0.03 * k)])
            h.publish("occupancy", cloud(both, k))
            h.spin_until(lambda k=k: len(h.received["tracks"]) >= k, timeout=10.0)
        last = h.received["tracks"][-1]
        assert last.header.frame_id == "room"
        assert [t.status for t in last.tracks] == [Track.STATUS_CONFIRMED] * 2
        assert all(t.state_layout == "x y z" for t in last.tracks)
        positions = np.array(sorted((t.state[0], t.state[1], t.state[2]) for t in last.tracks))
        assert positions[:, :2] == pytest.approx(np.array([[1.45, 1.0], [3.0, 3.55]]), abs=0.15)
        # the mean of a standing body's surface: the head's top is one, the soles on the floor not
        assert positions[:, 2] == pytest.approx([0.85, 0.85], abs=0.35)
    finally:
        h.close()


@pytest.mark.ros
def test_the_installed_executable_runs_with_the_shipped_params_file(tmp_path):
    """`ros2 run tracker_filter voxel_tracker --ros-args --params-file voxel_tracker.yaml` (the
    launch file's defaults) tracks a person walking through its room."""
    from pathlib import Path

    from ros_process import INSTALL, RosProcess

    params = (
        INSTALL / "tracker_filter" / "share" / "tracker_filter" / "config" / "voxel_tracker.yaml"
    )
    assert Path(params).exists()
    node = RosProcess(
        "tracker_filter", "voxel_tracker", "--ros-args", "--params-file", str(params),
        "-p", f"voxel_size:={VOXEL}", log_dir=tmp_path,
    )  # fmt: skip
    context = rclpy.Context()
    rclpy.init(context=context)
    peer = rclpy.create_node("voxel_peer", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(peer)
    received: list = []
    try:
        publisher = peer.create_publisher(PointCloud2, "occupancy", 10)
        peer.create_subscription(TrackArray, "tracks", received.append, 10)
        # a liveness deadline, not a speed target: with numba's cache cold the first cloud
        # compiles the kernels (seconds on a loaded machine)
        deadline = time.monotonic() + 60.0
        k = 0
        while not any(t.status == Track.STATUS_CONFIRMED for m in received for t in m.tracks):
            assert time.monotonic() < deadline, node.output()
            k += 1
            publisher.publish(cloud(person(1.0 + 0.05 * k, 2.0), k))
            executor.spin_once(timeout_sec=0.1)
        assert received[-1].tracks[0].state_layout == "x y z"
    finally:
        executor.shutdown()
        peer.destroy_node()
        rclpy.shutdown(context=context)
        assert node.interrupt(timeout=5.0) == 0, node.output()
        node.kill()
