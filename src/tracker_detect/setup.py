from glob import glob

from setuptools import find_packages, setup

package_name = "tracker_detect"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/models", glob("models/*")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Tracker suite maintainers",
    maintainer_email="maintainers@tracker-suite.dev",
    description=(
        "Motion detection for a moving pan-tilt camera: SSIM change detection with "
        "ego-motion compensation (seed 000)."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "detector = tracker_detect.entry_points:detector",
        ],
    },
)
