"""ExitDeadline: the process ends with the chosen code at the deadline even while a C call holds
the interpreter lock, and a cancelled deadline does nothing."""

from __future__ import annotations

import subprocess
import sys
import time

PROGRAM = """
import ctypes, sys
from tracker_msgs_py.exit_deadline import ExitDeadline
deadline = ExitDeadline({seconds}, {code})
ctypes.PyDLL(None).usleep({block_us})  # keeps the interpreter lock while it sleeps
{after}
print("carried on", flush=True)
"""


def run(seconds: float, code: int, block_s: float, after: str = "") -> tuple[int, str, float]:
    program = PROGRAM.format(seconds=seconds, code=code, block_us=int(block_s * 1e6), after=after)
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, timeout=30
    )
    return result.returncode, result.stdout + result.stderr, time.monotonic() - started


def test_the_deadline_exits_with_its_code_while_the_interpreter_lock_is_held():
    code, output, elapsed = run(seconds=0.5, code=7, block_s=20)
    assert code == 7, output
    assert elapsed < 10
    assert "carried on" not in output
    assert "Timeout" in output  # the stacks were written first


def test_the_exit_code_can_be_zero():
    code, output, _ = run(seconds=0.3, code=0, block_s=20)
    assert code == 0, output
    assert "carried on" not in output


def test_a_cancelled_deadline_lets_the_process_carry_on():
    code, output, _ = run(
        seconds=0.5, code=7, block_s=0.1, after="deadline.cancel(); import time; time.sleep(1)"
    )
    assert code == 0, output
    assert "carried on" in output
    assert "Timeout" not in output
