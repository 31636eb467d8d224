"""The recorded scene as a camera: frame readers (`frame_sources`), replay pacing and lockstep
(`replay`), the pan-tilt-zoom window over the scene (`camera_model`), synthetic scenes with ground
truth (`scenes`), and their nodes (`video_source_node`, `ptz_camera_node`).

Depends on tracker_msgs_py only; nothing here imports control, evaluation or bringup."""
