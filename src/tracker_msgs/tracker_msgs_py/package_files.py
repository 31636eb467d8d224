"""Where a package's shared files (config/, msg/, launch/) are: the install space, else the source
tree this module runs from. No rclpy."""

from __future__ import annotations

from pathlib import Path

SOURCE_DIR = Path(__file__).resolve().parents[2]  # src/ when running from the source tree


def package_data(package: str, subdir: str) -> Path:
    """share/<package>/<subdir> of the installed package, else src/<package>/<subdir>."""
    try:
        from ament_index_python.packages import get_package_share_directory

        installed = Path(get_package_share_directory(package)) / subdir
        if installed.is_dir():
            return installed
    except (ImportError, LookupError, ValueError):
        pass
    return SOURCE_DIR / package / subdir
