"""The package's executables (setup.py console_scripts).

Each installs the stop-signal handlers before importing rclpy, OpenCV and its node, so Ctrl-C or
SIGTERM at any moment of start-up ends it cleanly (`tracker_msgs_py.stop_signals`). Keep this
module free of other imports.
"""

from tracker_msgs_py.stop_signals import guarded_main


def video_source() -> int:
    return guarded_main("tracker_ptz_sim.simulation.video_source_node")


def ptz_camera() -> int:
    return guarded_main("tracker_ptz_sim.simulation.ptz_camera_node")


def ptz_controller() -> int:
    return guarded_main("tracker_ptz_sim.control.ptz_controller_node")


def ptz_state_bridge() -> int:
    return guarded_main("tracker_ptz_sim.control.ptz_state_bridge_node")


def axis_ptz_adapter() -> int:
    return guarded_main("tracker_ptz_sim.control.axis_ptz_adapter_node")


def onvif_ptz() -> int:
    return guarded_main("tracker_ptz_sim.control.onvif_ptz_node")


def ptz_tf() -> int:
    return guarded_main("tracker_ptz_sim.control.ptz_tf_node")


def live_view() -> int:
    return guarded_main("tracker_ptz_sim.bringup.live_view_node")


def graph_host() -> int:
    return guarded_main("tracker_ptz_sim.bringup.graph_host")


def run_demo() -> int:
    return guarded_main("tracker_ptz_sim.bringup.demo")


def run_launch() -> int:
    return guarded_main("tracker_ptz_sim.bringup.launch_runner")


def evaluate() -> int:
    return guarded_main("tracker_ptz_sim.bringup.evaluate")


def benchmark() -> int:
    return guarded_main("tracker_ptz_sim.bringup.benchmark", batch=True)


def predictor_study() -> int:
    return guarded_main("tracker_ptz_sim.bringup.predictor_study", batch=True)


def single_target_benchmark() -> int:
    return guarded_main("tracker_ptz_sim.bringup.single_target_benchmark", batch=True)


def phd_benchmark() -> int:
    return guarded_main("tracker_ptz_sim.bringup.phd_benchmark", batch=True)


def voxel_benchmark() -> int:
    return guarded_main("tracker_ptz_sim.bringup.voxel_benchmark", batch=True)


def annotate() -> int:
    return guarded_main("tracker_ptz_sim.annotation.cli", batch=True)


def parameter_tables() -> int:
    return guarded_main("tracker_ptz_sim.bringup.parameter_tables", batch=True)
