"""The graph's nodes as child processes, started from the install space as `ros2 run` would
(no rclpy): start, restart, stop, and say why one ended, with its last log lines."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections import deque
from pathlib import Path
from typing import Any

from tracker_msgs_py import stop_signals
from tracker_ptz_sim.bringup.graph import (
    MALLOC_TUNABLES,
    Graph,
    NodeSpec,
    executable_path,
    override_arguments,
    ros_args,
)

LOG_TAIL_LINES = 8
UDP_PROFILE = "fastdds_udp.xml"  # in the graph's config directory
HOST = "graph_host"  # the one process of a single-process run
STACK_DUMP_WAIT_S = 0.5  # for a node that does not stop to write its threads' stacks to its log


class GraphProcesses:
    """One process and one log file (logs/<name>.log, appended across restarts) per node."""

    @staticmethod
    def without_shared_memory(graph: Graph) -> dict[str, str]:
        """The environment that keeps Fast DDS off shared memory (config/fastdds_udp.xml)."""
        return {
            "FASTRTPS_DEFAULT_PROFILES_FILE": str(graph.config_dir / UDP_PROFILE),
            "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
        }

    def __init__(
        self,
        graph: Graph,
        install_dir: Path,
        log_dir: Path,
        environment: dict[str, str] | None = None,
        executor: str | None = None,
    ) -> None:
        """`executor`: the rclpy executor every node process spins (`node_main.EXECUTORS`;
        None: the nodes' default)."""
        self.graph = graph
        self.executor_arguments = [] if executor is None else ["--executor", executor]
        self.environment = environment or {}  # set for every node, over this process's
        self.install_dir = install_dir
        self.log_dir = log_dir
        self.processes: dict[str, subprocess.Popen] = {}
        self._cpu: dict[str, float] = {}  # last CPU time seen per node (kept after it exits)
        log_dir.mkdir(parents=True, exist_ok=True)

    def log_path(self, name: str) -> Path:
        return self.log_dir / f"{name}.log"

    def start(self, name: str, overrides: dict[str, Any] | None = None) -> subprocess.Popen:
        node = self.graph.node(name)
        command = [str(executable_path(self.install_dir, node)), *self.executor_arguments]
        command += ros_args(node, self.graph.params_files, overrides)
        return self._spawn(name, command)

    def start_host(
        self, overrides: dict[str, dict[str, Any]], live: bool = False
    ) -> subprocess.Popen:
        """Every node of the graph in one process (graph_host), watched as `graph_host`."""
        host = NodeSpec("tracker_ptz_sim", "graph_host", HOST)
        command = [str(executable_path(self.install_dir, host)), "--graph", self.graph.name]
        command += override_arguments(overrides) + (["--live"] if live else [])
        command += self.executor_arguments
        return self._spawn(HOST, command)

    def _spawn(self, name: str, command: list[str]) -> subprocess.Popen:
        with self.log_path(name).open("a") as log:
            self.processes[name] = subprocess.Popen(
                command,
                stdout=log,
                stderr=subprocess.STDOUT,
                env={"GLIBC_TUNABLES": MALLOC_TUNABLES, **os.environ, **self.environment},
                start_new_session=True,
            )
        return self.processes[name]

    def kill(self, name: str) -> None:
        """SIGKILL a node (as a crash would); it is no longer watched until started again."""
        process = self.processes.pop(name)
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()

    def stop_all(self, timeout: float = 5.0) -> dict[str, int]:
        """SIGINT every node, escalate to SIGKILL after `timeout`; the exit codes by node. A node
        still running at the deadline first writes its threads' stacks to its log (SIGUSR1)."""
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + timeout
        codes = {}
        for name, process in self.processes.items():
            try:
                codes[name] = process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                process.send_signal(stop_signals.STACK_DUMP_SIGNAL)
                time.sleep(STACK_DUMP_WAIT_S)
                os.killpg(process.pid, signal.SIGKILL)
                codes[name] = process.wait()
        return codes

    def exited(self) -> dict[str, int]:
        """The watched nodes that are no longer running, with their exit codes."""
        return {
            name: code
            for name, process in self.processes.items()
            if (code := process.poll()) is not None
        }

    def cpu_seconds(self) -> dict[str, float]:
        """CPU time (user + system) each node has used, from /proc: now for a running node, at
        the last call before it exited for one that did (call often to miss little of it)."""
        ticks = os.sysconf("SC_CLK_TCK")
        for name, process in self.processes.items():
            try:
                fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            # An exited, not yet reaped process still has its final times here.
            self._cpu[name] = (int(fields[11]) + int(fields[12])) / ticks  # utime, stime
        return dict(self._cpu)

    def last_log_lines(self, name: str, count: int = LOG_TAIL_LINES) -> list[str]:
        try:
            with self.log_path(name).open(errors="replace") as log:
                return [line.rstrip("\n") for line in deque(log, maxlen=count)]
        except OSError:
            return []

    def death_report(self, name: str, code: int) -> str:
        """'ssim_detector was killed by SIGKILL; its last log lines: ...' (several lines)."""
        tail = self.last_log_lines(name)
        lines = "\n".join(f"    {line}" for line in tail) if tail else "    (nothing logged)"
        return f"{name} {describe_exit(code)}; its last log lines ({self.log_path(name)}):\n{lines}"


def describe_exit(code: int) -> str:
    """How a process ended, from its Popen return code."""
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    if code == 0:
        return "exited with code 0 (stopped from outside?)"
    if code == 2:
        return "could not start (exit code 2)"
    return f"failed with exit code {code}"
