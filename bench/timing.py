"""What the benchmark scripts share: per-call timing summaries and writing the results file."""

from __future__ import annotations

import json
import os
import platform
import statistics
from pathlib import Path
from typing import Any


def summary(times: list[float]) -> dict:
    """Median, 95th percentile and mean of per-call times (ms)."""
    ordered = sorted(times)
    return {
        "median_ms": statistics.median(ordered),
        "p95_ms": ordered[int(0.95 * (len(ordered) - 1))],
        "mean_ms": statistics.fmean(ordered),
    }


def machine(**extra: Any) -> dict:
    """The machine a results file was measured on (plus `extra` library versions)."""
    return {
        "python": platform.python_version(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
    } | extra


def write_results(path: Path, results: dict, root: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(results, indent=2) + "\n")
    print(f"\nwrote {path.relative_to(root)}")
