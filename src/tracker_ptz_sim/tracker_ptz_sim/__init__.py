"""Recorded video and rosbag2 replay as a camera stream, a simulated pan-tilt-zoom camera, the
pan-tilt controller, the surveillance demo graph and synthetic scenes with ground truth."""
