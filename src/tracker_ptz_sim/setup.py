from glob import glob
from os.path import isfile

from setuptools import find_packages, setup

package_name = "tracker_ptz_sim"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/config", glob("config/*.yaml") + glob("config/*.xml")),
        *(  # annotated clips: annotations/<clip>/ and its gt/ (not the review's sheets)
            (f"share/{package_name}/{folder}", [p for p in glob(f"{folder}/*") if isfile(p)])
            for folder in glob("annotations/*") + glob("annotations/*/gt")
        ),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Tracker suite maintainers",
    maintainer_email="maintainers@tracker-suite.dev",
    description=(
        "Recorded video and rosbag2 replay as a camera stream, a simulated pan-tilt-zoom "
        "camera, the pan-tilt controller, the surveillance demo graph and synthetic "
        "scenes with ground truth."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "video_source = tracker_ptz_sim.entry_points:video_source",
            "ptz_camera = tracker_ptz_sim.entry_points:ptz_camera",
            "ptz_controller = tracker_ptz_sim.entry_points:ptz_controller",
            "ptz_state_bridge = tracker_ptz_sim.entry_points:ptz_state_bridge",
            "ptz_tf = tracker_ptz_sim.entry_points:ptz_tf",
            "axis_ptz_adapter = tracker_ptz_sim.entry_points:axis_ptz_adapter",
            "onvif_ptz = tracker_ptz_sim.entry_points:onvif_ptz",
            "live_view = tracker_ptz_sim.entry_points:live_view",
            "graph_host = tracker_ptz_sim.entry_points:graph_host",
            "run_demo = tracker_ptz_sim.entry_points:run_demo",
            "run_launch = tracker_ptz_sim.entry_points:run_launch",
            "fetch_sample = tracker_ptz_sim.bringup.sample:main",
            "make_scene = tracker_ptz_sim.simulation.scene_cli:main",
            "annotate = tracker_ptz_sim.entry_points:annotate",
            "evaluate = tracker_ptz_sim.entry_points:evaluate",
            "benchmark = tracker_ptz_sim.entry_points:benchmark",
            "predictor_study = tracker_ptz_sim.entry_points:predictor_study",
            "single_target_benchmark = tracker_ptz_sim.entry_points:single_target_benchmark",
            "phd_benchmark = tracker_ptz_sim.entry_points:phd_benchmark",
            "voxel_benchmark = tracker_ptz_sim.entry_points:voxel_benchmark",
            "parameter_tables = tracker_ptz_sim.entry_points:parameter_tables",
        ],
    },
)
