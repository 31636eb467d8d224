"""Start the suite's executables from the install space, exactly as `ros2 run` would, and stop them."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INSTALL = ROOT / "install"


def executable(package: str, name: str) -> Path:
    """install/<package>/lib/<package>/<name>, the file `ros2 run <package> <name>` executes."""
    path = INSTALL / package / "lib" / package / name
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: run 'make setup' (colcon build) first")
    return path


def installed_executables() -> dict[str, list[str]]:
    """Every executable installed under install/<pkg>/lib/<pkg>/, by package."""
    found: dict[str, list[str]] = {}
    for lib_dir in sorted(INSTALL.glob("*/lib/*")):
        package = lib_dir.name
        if lib_dir.parent.parent.name != package or not lib_dir.is_dir():
            continue
        names = sorted(p.name for p in lib_dir.iterdir() if p.is_file() and os.access(p, os.X_OK))
        if names:
            found[package] = names
    return found


class RosProcess:
    """A node (or tool) running in its own process; output goes to a log file for diagnostics."""

    def __init__(
        self,
        package: str,
        name: str,
        *args: str,
        log_dir: Path,
        params: dict[str, object] | None = None,
        env: dict[str, str] | None = None,
    ):
        command = [str(executable(package, name)), *args]
        if params:
            command += ["--ros-args"] + [
                item for key, value in params.items() for item in ("-p", f"{key}:={_param(value)}")
            ]
        self.name = name
        log_dir.mkdir(parents=True, exist_ok=True)
        self.log_path = log_dir / f"{name}-{time.monotonic_ns()}.log"
        self._log = self.log_path.open("w")
        self.process = subprocess.Popen(
            command,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env={**os.environ, **(env or {})},
            start_new_session=True,
        )

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text()

    def interrupt(self, timeout: float, signum: int = signal.SIGINT) -> int | None:
        """Send SIGINT (Ctrl-C) or `signum` and wait up to `timeout` s; the exit code, or None if
        still running."""
        if self.process.poll() is None:
            self.process.send_signal(signum)
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None

    def wait(self, timeout: float) -> int:
        return self.process.wait(timeout=timeout)

    def kill(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()
        self._log.close()


def _param(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | tuple):
        return "[" + ",".join(_param(v) for v in value) + "]"
    return str(value)
