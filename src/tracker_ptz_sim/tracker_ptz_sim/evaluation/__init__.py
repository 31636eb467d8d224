"""Measuring runs: rosbag2 recording and reading (`recording`), CLEAR MOT / IDF1 and follow scores
(`metrics`, `scoring`), the run summary and annotated video (`run_report`).

Depends on tracker_msgs_py only (decoding through `tracker_msgs_py.codec`); never on bringup."""
