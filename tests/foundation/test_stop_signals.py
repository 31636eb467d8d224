"""Stop signals during a node's imports end the process at once with 0, whatever the import turns
the stop into; after the imports they only set the flag the node polls."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tracker_msgs_py import stop_signals

ROOT = Path(__file__).resolve().parents[2]
MODULES = {
    # Signals itself while being imported, then would import for a long time.
    "plain": "import os, signal, time\nos.kill(os.getpid(), signal.SIGTERM)\ntime.sleep(10)\n",
    # As a C extension's initialisation does: the SystemExit comes out as an ImportError.
    "converted": (
        "import os, signal, time\n"
        "try:\n    os.kill(os.getpid(), signal.SIGINT)\n    time.sleep(10)\n"
        "except BaseException as error:\n    raise ImportError('initialization failed') from error\n"
    ),
    # Leaves a worker thread that never ends: the interpreter's shutdown would wait for it.
    "half_done": (
        "import os, signal, threading, time\n"
        "threading.Thread(target=time.sleep, args=(30,)).start()\n"
        "os.kill(os.getpid(), signal.SIGTERM)\ntime.sleep(10)\n"
    ),
    # Imports fine; its main polls the flag, as run_node does, and exits 0 once it is set.
    "running": (
        "import os, signal\nfrom tracker_msgs_py import stop_signals\n"
        "def main():\n    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    assert stop_signals.wait(5.0) and stop_signals.received() == 'SIGTERM'\n"
        "    return 0\n"
    ),
}


def _run_guarded(
    tmp_path: Path, module: str, source: str, batch: bool = False
) -> subprocess.CompletedProcess[str]:
    """`source` saved as `module` and run by guarded_main in a fresh interpreter."""
    (tmp_path / f"{module}.py").write_text(source)
    code = (
        "import sys\nfrom tracker_msgs_py.stop_signals import guarded_main\n"
        f"sys.exit(guarded_main('{module}', batch={batch}))\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=20,
        env={"PYTHONPATH": f"{tmp_path}:{ROOT / 'src' / 'tracker_msgs'}"},
    )


@pytest.mark.parametrize("case", sorted(MODULES))
def test_a_stop_at_any_point_of_start_up_exits_0_at_once(case, tmp_path):
    started = time.monotonic()
    result = _run_guarded(tmp_path, f"node_{case}", MODULES[case])
    assert result.returncode == 0, result.stderr
    assert result.stderr == "" and time.monotonic() - started < 5.0


def test_a_process_that_does_not_stop_writes_its_threads_stacks_when_asked():
    """What the graph runner sends a node that ignores its stop before killing it: every
    thread's Python stack goes to stderr (the node's log), naming where it hangs."""
    code = (
        "import threading, time\nfrom tracker_msgs_py import stop_signals\n"
        "stop_signals.install()\n"
        "def stuck_in_teardown():\n    time.sleep(30)\n"
        "threading.Thread(target=stuck_in_teardown, daemon=True).start()\n"
        "print('ready', flush=True)\ntime.sleep(30)\n"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", code],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={"PYTHONPATH": str(ROOT / "src" / "tracker_msgs")},
    )
    try:
        assert process.stdout.readline() == "ready\n"
        process.send_signal(signal.SIGINT)  # only sets the flag, which this process ignores
        process.send_signal(stop_signals.STACK_DUMP_SIGNAL)
        time.sleep(0.5)
    finally:
        process.kill()
        _, stderr = process.communicate(timeout=10)
    assert "most recent call first" in stderr
    assert "stuck_in_teardown" in stderr  # every thread, not only the main one


BATCH_MODULES = {
    # Computes and never polls: the stop interrupts it where it is.
    "computing": (
        "import os, signal\n"
        "def main():\n    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    while True:\n        sum(range(1000))\n"
    ),
    # A part that stops in order itself (a graph run) sees a flag, then the tool ends.
    "deferred": (
        "import os, signal\nfrom tracker_msgs_py import stop_signals\n"
        "def main():\n    with stop_signals.deferred():\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        assert stop_signals.wait(5.0)\n"
        "        print('stopped in order', flush=True)\n"
        "    print('went on after the stop', flush=True)\n    return 0\n"
    ),
}


@pytest.mark.parametrize(
    "case, expected_stdout, expected_stderr",
    [
        ("computing", "", "interrupted by SIGTERM\n"),
        ("deferred", "stopped in order\n", "interrupted by SIGINT\n"),
    ],
)
def test_a_batch_tool_ends_on_a_stop_with_one_line_and_130(
    case, expected_stdout, expected_stderr, tmp_path
):
    """Benchmarks and studies (guarded_main(batch=True)) stop on Ctrl-C instead of ignoring it;
    a part inside them that stops in order (deferred) finishes its own stop first."""
    result = _run_guarded(tmp_path, f"tool_{case}", BATCH_MODULES[case], batch=True)
    assert result.returncode == stop_signals.INTERRUPTED_EXIT_CODE == 130
    assert (result.stdout, result.stderr) == (expected_stdout, expected_stderr)
