from glob import glob

from setuptools import find_packages, setup

package_name = "tracker_filter"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Tracker suite maintainers",
    maintainer_email="maintainers@tracker-suite.dev",
    description=(
        "Alpha-beta and Kalman tracking with multi-target track management and target selection."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "tracker = tracker_filter.entry_points:tracker",
            "voxel_tracker = tracker_filter.entry_points:voxel_tracker",
        ],
    },
)
