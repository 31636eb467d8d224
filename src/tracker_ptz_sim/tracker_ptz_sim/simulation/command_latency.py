"""How long the graph takes to answer a camera image with a command, timed at the camera (no rclpy).

The camera knows when an image left it and when the command carrying that image's stamp came
back: the latency a pan-tilt unit sees, from its image out to its command in (every node,
serialization and transport on the way), on one clock. A recorder's receive times measure the
same only to within the recorder's own lag.
"""

from __future__ import annotations

from collections import OrderedDict, deque
from collections.abc import Iterable

import numpy as np

NS_PER_MS = 1_000_000
#: the camera's diagnostics carry "<DIAGNOSTICS_KEY> p50 [ms]", "... p95 [ms]", "... max [ms]"
#: and "<DIAGNOSTICS_KEY> count"
DIAGNOSTICS_KEY = "camera image to command"


class CommandLatency:
    """Per image stamp, the wall time (monotonic ns) the image went out; per command answering
    one of them, the time since, in ms.

    At most `pending_limit` images wait for their command (the oldest are forgotten: a command
    that never comes, a graph that skips frames); the last `kept` latencies are kept."""

    def __init__(self, pending_limit: int = 256, kept: int = 100_000) -> None:
        if pending_limit < 1 or kept < 1:
            raise ValueError(f"need pending_limit and kept >= 1, got {pending_limit}, {kept}")
        self.pending_limit = pending_limit
        self._sent: OrderedDict[int, int] = OrderedDict()
        self._latencies_ms: deque[float] = deque(maxlen=kept)

    def image_sent(self, stamp_ns: int, now_ns: int) -> None:
        """The image stamped `stamp_ns` went out at `now_ns` (the first time counts)."""
        self._sent.setdefault(stamp_ns, now_ns)
        while len(self._sent) > self.pending_limit:
            self._sent.popitem(last=False)

    def command_received(self, stamp_ns: int, now_ns: int) -> float | None:
        """A command stamped `stamp_ns` came in at `now_ns`: its image's latency (ms), or None
        when no image of that stamp waits (a second command for it, or an unknown stamp)."""
        sent = self._sent.pop(stamp_ns, None)
        if sent is None:
            return None
        latency = (now_ns - sent) / NS_PER_MS
        self._latencies_ms.append(latency)
        return latency

    def forget_pending(self) -> None:
        """A new replay epoch: the images waiting will not be answered (the latencies stay)."""
        self._sent.clear()

    def __len__(self) -> int:
        """How many commands were timed."""
        return len(self._latencies_ms)

    def stats(self) -> dict[str, float]:
        """p50, p95 and max of the latencies (ms); empty before the first command."""
        if not self._latencies_ms:
            return {}
        values = np.fromiter(self._latencies_ms, float)
        return {
            "p50": float(np.percentile(values, 50)),
            "p95": float(np.percentile(values, 95)),
            "max": float(values.max()),
        }


def diagnostics_values(latency: CommandLatency) -> dict[str, str]:
    """The figures the camera reports in its diagnostics (none before the first command)."""
    if not len(latency):
        return {}
    figures = {
        f"{DIAGNOSTICS_KEY} {name} [ms]": f"{value:.2f}" for name, value in latency.stats().items()
    }
    return figures | {f"{DIAGNOSTICS_KEY} count": str(len(latency))}


def from_diagnostics(values: Iterable[tuple[str, str]]) -> dict[str, float]:
    """`diagnostics_values` read back from a status's (key, value) pairs: p50, p95, max (ms) and
    count; empty when they hold none."""
    found: dict[str, float] = {}
    for key, value in values:
        if not key.startswith(DIAGNOSTICS_KEY + " "):
            continue
        name = key[len(DIAGNOSTICS_KEY) + 1 :].removesuffix(" [ms]")
        try:
            found[name] = float(value)
        except ValueError:
            continue
    return found
