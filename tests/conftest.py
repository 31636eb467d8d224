"""Shared test setup: source-tree imports for the pure-Python cores, DDS isolation for ROS tests."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# The cores import from source; shared test helpers (ros_process.py, ...) import from tests/.
for path in [
    ROOT / "src" / pkg
    for pkg in ("tracker_msgs", "tracker_detect", "tracker_filter", "tracker_ptz_sim")
] + [ROOT / "tests"]:
    if str(path) not in sys.path:
        sys.path.insert(0, str(path))

# Every test run gets its own DDS domain on localhost only, so concurrent runs never cross-talk,
# in the range whose ports stay clear of Linux's ephemeral ones (tracker_msgs_py.ros_domain).
# Child processes started by tests inherit these.
from tracker_msgs_py.ros_domain import private_domain_id  # noqa: E402

os.environ.setdefault("ROS_DOMAIN_ID", str(private_domain_id(os.getpid(), taken=0)))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")


import pytest  # noqa: E402


@pytest.fixture(scope="session")
def vtest_clip() -> Path:
    """OpenCV's vtest.avi (real pedestrians; the annotated clip), fetched once like `make sample`
    does (Debian's opencv-doc package); skipped only on a machine without apt."""
    from tracker_ptz_sim.bringup.sample import SampleUnavailableError, fetch_sample

    try:
        return fetch_sample()
    except SampleUnavailableError as error:
        pytest.skip(f"vtest.avi is not available: {error}")
