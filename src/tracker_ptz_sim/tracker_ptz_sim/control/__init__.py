"""Pointing the camera: the hardware-neutral pan-tilt controller (`controller`: PI servo and direct
pointing) and its node (`ptz_controller_node`). Depends on tracker_msgs_py only."""
