"""Bad-input reporting shared by the suite's nodes (no rclpy): one warning per distinct cause,
then a count.

A node that drops a malformed or out-of-order message calls `report(cause, detail)`. The first
time a cause is seen, `detail` is logged as a warning that names it; later reports of the same
cause are only counted, so a flood of one problem cannot hide a different one behind a throttle
(a different cause gets its own warning at once). Counts are available for diagnostics and are
summarised when the node stops.
"""

from __future__ import annotations

from collections.abc import Callable


class ProblemLog:
    """Counts of dropped inputs by cause, warning once per cause through `warn`."""

    def __init__(self, warn: Callable[[str], None]) -> None:
        self._warn = warn
        self.counts: dict[str, int] = {}
        self.revision = 0  # changes whenever a count does (for publishers of diagnostics)

    def report(self, cause: str, detail: str, count: int = 1) -> bool:
        """Count `count` occurrences of `cause`; log `detail` if it is new. True if logged."""
        first = cause not in self.counts
        self.counts[cause] = self.counts.get(cause, 0) + count
        self.revision += 1
        if first:
            self._warn(f"{detail} [{cause}: further ones are counted, not logged]")
        return first

    def count(self, cause: str) -> int:
        return self.counts.get(cause, 0)

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    def summary(self) -> str:
        """'3 x stale stamp, 1 x unknown command mode', or '' when nothing was dropped."""
        return ", ".join(f"{n} x {cause}" for cause, n in sorted(self.counts.items()))
