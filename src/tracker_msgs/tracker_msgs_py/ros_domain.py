"""A private ROS domain for test and benchmark runs (no rclpy).

DDS derives its UDP ports from the domain ID (Fast DDS: 7400 + 250 x domain + a few per
participant). From domain 102 on they fall into Linux's ephemeral port range (32768-60999), where
any socket the system opens can take a port a participant later needs; ROS 2's documentation
therefore calls 0-101 the safe range on Linux.
"""

from __future__ import annotations

SAFE_DOMAINS = 101  # domains 1..101: 0 is everyone's default


def private_domain_id(pid: int, taken: int | None) -> int:
    """A ROS domain in 1-101 picked by `pid`, other than `taken` (the environment's)."""
    domain = 1 + pid % SAFE_DOMAINS
    return domain if domain != taken else 1 + (domain % SAFE_DOMAINS)
