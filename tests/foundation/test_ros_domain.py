"""The private ROS domains of test and benchmark runs."""

from __future__ import annotations

from tracker_msgs_py.ros_domain import private_domain_id


def test_private_domains_stay_in_the_safe_range_and_off_the_environments():
    """Never the environment's domain (a demo there would feed the lockstep replay), always one
    whose ports stay below Linux's ephemeral range."""
    for pid in range(1, 2000):
        for taken in (0, 1, 42, 101, None):
            domain = private_domain_id(pid, taken)
            assert 1 <= domain <= 101 and domain != taken
