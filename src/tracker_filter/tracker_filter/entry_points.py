"""The package's executables (setup.py console_scripts).

Each installs the stop-signal handlers before importing rclpy, NumPy and its node, so Ctrl-C or
SIGTERM at any moment of start-up ends it cleanly (`tracker_msgs_py.stop_signals`). Keep this
module free of other imports.
"""

from tracker_msgs_py.stop_signals import guarded_main


def tracker() -> int:
    return guarded_main("tracker_filter.tracker_node")


def voxel_tracker() -> int:
    return guarded_main("tracker_filter.voxel_tracker_node")
