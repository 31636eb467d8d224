"""A scored run's files: its tracks (MOT), its scores (JSON) and its plots (PNG).

Apart from `scoring`, which computes the scores, because the plots need matplotlib and read the
scores' traces: `scoring` does not import the plotting.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tracker_ptz_sim.evaluation import metrics, scoring
from tracker_ptz_sim.evaluation.plots import plot_run


def write_evaluation(
    trace: scoring.RunTrace,
    gt: Path,
    out: Path,
    title: str = "",
    label_of: scoring.LabelImages | None = None,
    centres: bool = False,
) -> dict[str, Any]:
    """Score a run (`score_trace`) and write tracks.txt, evaluation.json and plots.png into
    `out`; the scores."""
    out.mkdir(parents=True, exist_ok=True)
    trace.write_mot(out / "tracks.txt")
    result = scoring.score_trace(trace, gt, label_of, centres)
    scoring.write_json(result, out / "evaluation.json")
    plot_run(trace, metrics.every_object(gt), out / "plots.png", title or str(gt))
    return result
