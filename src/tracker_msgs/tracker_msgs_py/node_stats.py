"""What a node reports on /diagnostics about its inputs, per topic and per reporting period (no
rclpy): message rate, time spent handling a message, and the data's age on arrival.

`InputStats.record(processing_s, age_s)` is called once per message received; `report(period_s)`
returns the figures since the previous report as (key, value) strings and starts a new period;
`busy_s` adds up the handling time since the node started (a node's time per frame, as wall time
in its callbacks, beside the CPU time its threads use).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

RECEIVED_SUFFIX = " received"  # "<topic> received": the messages since the node started


@dataclass
class InputStats:
    """One input topic's figures over the current reporting period."""

    messages: int = 0
    total: int = 0  # since the node started
    processing_sum_s: float = 0.0
    processing_max_s: float = 0.0
    age_sum_s: float = 0.0
    aged: int = 0  # messages with a stamp (ages summed)
    busy_s: float = 0.0  # handling time since the node started
    last_at: float | None = None  # time.monotonic() of the latest message

    def record(self, processing_s: float, age_s: float | None = None) -> None:
        self.last_at = time.monotonic()
        self.messages += 1
        self.total += 1
        self.busy_s += processing_s
        self.processing_sum_s += processing_s
        self.processing_max_s = max(self.processing_max_s, processing_s)
        if age_s is not None and math.isfinite(age_s):
            self.age_sum_s += age_s
            self.aged += 1

    def report(self, topic: str, period_s: float) -> list[tuple[str, str]]:
        """`topic rate [Hz]`, `topic processing mean/max [ms]`, `topic age mean [ms]` (when
        stamped) and `topic received`, then a new period begins."""
        figures = [
            (f"{topic} rate [Hz]", f"{self.messages / period_s:.2f}" if period_s > 0 else "0"),
            (f"{topic}{RECEIVED_SUFFIX}", str(self.total)),
        ]
        if self.messages:
            mean_ms = 1e3 * self.processing_sum_s / self.messages
            figures.append(
                (
                    f"{topic} processing mean/max [ms]",
                    f"{mean_ms:.2f}/{1e3 * self.processing_max_s:.2f}",
                )
            )
        if self.aged:
            figures.append(
                (f"{topic} age on arrival mean [ms]", f"{1e3 * self.age_sum_s / self.aged:.1f}")
            )
        self.messages, self.aged = 0, 0
        self.processing_sum_s = self.processing_max_s = self.age_sum_s = 0.0
        return figures
