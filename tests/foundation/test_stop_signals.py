"""Stop signals during a node's imports end the process at once with 0, whatever the import turns
the stop into; after the imports they only set the flag the node polls."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

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
    # Imports fine; its main polls the flag, as run_node does, and exits 0 once it is set.
    "running": (
        "import os, signal\nfrom tracker_msgs_py import stop_signals\n"
        "def main():\n    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    assert stop_signals.wait(5.0) and stop_signals.received() == 'SIGTERM'\n"
        "    return 0\n"
    ),
}


@pytest.mark.parametrize("case", sorted(MODULES))
def test_a_stop_at_any_point_of_start_up_exits_0_at_once(case, tmp_path):
    (tmp_path / f"node_{case}.py").write_text(MODULES[case])
    code = (
        "import sys\nfrom tracker_msgs_py.stop_signals import guarded_main\n"
        f"sys.exit(guarded_main('node_{case}'))\n"
    )
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=20,
        env={"PYTHONPATH": f"{tmp_path}:{ROOT / 'src' / 'tracker_msgs'}"},
    )
    assert result.returncode == 0, result.stderr
    assert result.stderr == "" and time.monotonic() - started < 5.0
