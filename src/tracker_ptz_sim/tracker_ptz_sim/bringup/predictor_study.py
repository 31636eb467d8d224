"""predictor_study: seed 001's prediction experiment (nominal vs robust Kalman), reproduced.

    predictor_study [--runs 100] [--seed 0] [--out out/predictors]

For each protocol (`evaluation.prediction_study.PROTOCOLS`) it runs the nominal filter and the
robust filter with both lambda_hat rules on the same noisy measurements, prints the mean one-step
prediction error over the last 80 frames (against the noisy and the true position) beside the
thesis's figures, and a paired comparison robust - nominal over the runs. Writes results.json and
one PNG per protocol (mean error per frame, as the thesis's live plot) into --out.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from dataclasses import asdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tracker_ptz_sim.evaluation import prediction_study as study  # noqa: E402


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=100, help="runs per protocol (thesis: 100)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first run")
    parser.add_argument("--out", type=Path, default=Path("out/predictors"))
    parser.add_argument(
        "--protocols", nargs="+", choices=list(study.PROTOCOLS), default=list(study.PROTOCOLS)
    )
    return parser.parse_args(argv)


def _thesis(predictor: str, protocol: str) -> str:
    if not protocol.startswith("concentric circles"):
        return ""
    value = study.THESIS_PX["nominal" if predictor == "nominal" else "robust"]
    return f"{value:.2f}"


def _table(results: list[study.ProtocolResult]) -> list[str]:
    lines = [
        "| protocol | predictor | E vs noisy [px] | thesis [px] | E vs true [px] |",
        "|---|---|---|---|---|",
    ]
    for result in results:
        for name, noisy in result.scored_noisy.items():
            true = result.scored_true[name]
            lines.append(
                f"| {result.protocol} | {name} | {noisy.mean():.2f} ± {noisy.std(ddof=1):.2f} "
                f"| {_thesis(name, result.protocol)} | {true.mean():.2f} ± {true.std(ddof=1):.2f} |"
            )
    lines += [
        "",
        "| protocol | robust rule | against | robust − nominal [px] | robust better | p (Wilcoxon) |",
        "|---|---|---|---|---|---|",
    ]
    for result in results:
        for rule in ("robust exact", "robust cheap"):
            for against in ("noisy", "true"):
                c = result.comparison(rule, against)
                lines.append(
                    f"| {result.protocol} | {rule} | {against} | {c.mean:+.2f} ± {c.std:.2f} "
                    f"| {c.robust_better}/{c.runs} | {c.p_value:.1e} |"
                )
    return lines


def _plot(result: study.ProtocolResult, path: Path, seed: int) -> None:
    """The thesis's live error plot: E_i per predictor over the first run, and the mean of all."""
    figure, (single, mean) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    seconds = [(i + 1) / study.FPS for i in range(study.FRAMES - 1)]
    runs = len(next(iter(result.scored_noisy.values())))
    for name, curve in result.first_run_noisy.items():
        single.plot(
            seconds, curve, lw=1, label=f"{name} ({curve[-study.SCORED_FRAMES :].mean():.1f} px)"
        )
    for name, curve in result.curves_noisy.items():
        mean.plot(seconds, curve, lw=1, label=f"{name} ({result.scored_noisy[name].mean():.1f} px)")
    for axis, title in ((single, f"run 1 of {runs} (seed {seed})"), (mean, f"mean of {runs} runs")):
        axis.axvspan(seconds[-study.SCORED_FRAMES], seconds[-1], color="0.9", label="scored frames")
        axis.set_ylabel("E_i [px]")
        axis.set_title(f"{result.protocol}: one-step prediction error, {title}", fontsize=10)
        axis.legend(loc="upper right", fontsize=8)
    mean.set_xlabel("time [s]")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _json(results: list[study.ProtocolResult]) -> list[dict]:
    out = []
    for result in results:
        out.append(
            {
                "protocol": result.protocol,
                "error_vs_noisy_px": {n: v.tolist() for n, v in result.scored_noisy.items()},
                "error_vs_true_px": {n: v.tolist() for n, v in result.scored_true.items()},
                "comparisons": {
                    f"{rule} vs nominal, {against}": asdict(result.comparison(rule, against))
                    for rule in ("robust exact", "robust cheap")
                    for against in ("noisy", "true")
                },
            }
        )
    return out


def main(argv: list[str] | None = None) -> int:
    args = _arguments(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    results = []
    for k, name in enumerate(args.protocols):

        def progress(done: int, name: str = name) -> None:
            print(f"\r{name}: run {done}/{args.runs}", end="", file=sys.stderr, flush=True)

        result = study.run_protocol(
            name, study.PROTOCOLS[name], args.runs, args.seed, None, progress
        )
        print(file=sys.stderr)
        slug = re.sub(r"[^a-z0-9]+", "_", name.split(" (")[0].lower()).strip("_")
        _plot(result, args.out / f"errors-{k}-{slug}.png", args.seed)
        results.append(result)
    table = _table(results)
    print("\n".join(table))
    (args.out / "table.md").write_text("\n".join(table) + "\n")
    (args.out / "results.json").write_text(json.dumps(_json(results), indent=1))
    print(f"\nwrote {args.out}/results.json, table.md and one errors-*.png per protocol")
    return 0


if __name__ == "__main__":
    sys.exit(main())
