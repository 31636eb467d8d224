"""Shutdown stress: SIGINT / SIGTERM at random moments, per node, inside a running graph.

    python scripts/stress_signals.py [--signals 50] [--nodes video_source,tracker] [--seed 0]
    make stress

For each node, the rest of the surveillance graph runs on a short looping synthetic clip in
lockstep, so the node under test has real input. Then, `--signals` times: the node is started,
and once its stop handler is installed (SIGTERM shows in /proc/<pid>/status SigCgt, ~50 ms after
exec: before that the interpreter's defaults apply, as for any process) it gets SIGINT or SIGTERM
(coin flip) after a uniform random delay in [0, --max-delay] s, which lands in start-up (imports,
node construction, discovery), mid-frame work and lockstep waits alike. A clean exit is code 0
within 2 s. Prints the exit-code histogram per node; exits 1 if any exit was not clean.
Run it from a shell with the workspace sourced (`source scripts/env.sh`).
"""

from __future__ import annotations

import argparse
import random
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from tracker_msgs_py import stop_signals
from tracker_ptz_sim.bringup.demo import install_space
from tracker_ptz_sim.bringup.graph import load_graph
from tracker_ptz_sim.bringup.processes import STACK_DUMP_WAIT_S, GraphProcesses
from tracker_ptz_sim.simulation.scene_files import write_scene
from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

CLEAN_EXIT_S = 2.0
HANDLER_TIMEOUT_S = 10.0
NODES = ("video_source", "ptz_camera", "ssim_detector", "tracker", "ptz_controller")


def handler_installed(pid: int) -> bool:
    """Whether the process catches SIGTERM (the suite's stop handler is in place)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    for line in status.splitlines():
        if line.startswith("SigCgt:"):
            return bool(int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1)
    return False


def wait_for_handler(process: subprocess.Popen) -> bool:
    deadline = time.monotonic() + HANDLER_TIMEOUT_S
    while time.monotonic() < deadline and process.poll() is None:
        if handler_installed(process.pid):
            return True
        time.sleep(0.002)
    return False


def trial(
    nodes: GraphProcesses, name: str, overrides: dict, rng: random.Random, max_delay: float
) -> tuple:
    """Start `name`, signal it at a random moment: (outcome, signal, delay s, exit time s)."""
    process = nodes.start(name, overrides)
    if not wait_for_handler(process):
        nodes.kill(name)
        return ("no handler", "-", 0.0, 0.0)
    delay = rng.uniform(0.0, max_delay)
    signum = rng.choice((signal.SIGINT, signal.SIGTERM))
    time.sleep(delay)
    if process.poll() is not None:
        nodes.processes.pop(name)
        return (f"ended before the signal ({process.returncode})", signum.name, delay, 0.0)
    sent = time.monotonic()
    process.send_signal(signum)
    try:
        code = process.wait(timeout=CLEAN_EXIT_S)
        outcome: object = code
    except subprocess.TimeoutExpired:
        outcome = f"still running after {CLEAN_EXIT_S} s"
        # its threads' stacks go to its log first: where it hung is then printed below
        process.send_signal(stop_signals.STACK_DUMP_SIGNAL)
        time.sleep(STACK_DUMP_WAIT_S)
    elapsed = time.monotonic() - sent
    nodes.kill(name)
    return (outcome, signum.name, delay, elapsed)


def clip(directory: Path) -> Path:
    scene = generate_scene(
        SceneConfig(width=320, height=240, num_frames=40, num_objects=2, fps=10.0, seed=5)
    )
    return write_scene(scene, directory).video


def stress_node(name: str, video: Path, args: argparse.Namespace, log_dir: Path) -> list[tuple]:
    graph = load_graph()
    nodes = GraphProcesses(graph, install_space(), log_dir / name)
    source = {"path": str(video), "loop": True, "wait_for_subscribers": 1}
    rng = random.Random(f"{args.seed}:{name}")
    results = []
    try:
        overrides = {"video_source": source}
        for other in NODES:
            if other != name:
                nodes.start(other, overrides.get(other))
        time.sleep(2.0)  # the rest of the graph is up and replaying
        for k in range(args.signals):
            results.append(trial(nodes, name, overrides.get(name, {}), rng, args.max_delay))
            outcome, signame, delay, elapsed = results[-1]
            if args.verbose or outcome != 0:
                print(
                    f"  {name} #{k + 1}: {signame} after {delay:.3f} s -> {outcome} in {elapsed:.3f} s"
                )
    finally:
        nodes.stop_all()
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--signals", type=int, default=50, help="signals per node")
    parser.add_argument("--nodes", default=",".join(NODES), help="comma-separated node names")
    parser.add_argument("--max-delay", type=float, default=3.0, help="latest signal [s]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--verbose", action="store_true", help="a line per signal")
    args = parser.parse_args(argv)
    clean = True
    with tempfile.TemporaryDirectory(prefix="stress_signals_") as temp:
        video = clip(Path(temp))
        print(f"{args.signals} signals per node, uniform in [0, {args.max_delay}] s after start")
        for name in args.nodes.split(","):
            results = stress_node(name, video, args, Path(temp) / "logs")
            histogram = Counter(outcome for outcome, *_ in results)
            times = sorted(elapsed for outcome, _, _, elapsed in results if outcome == 0)
            slowest = f", slowest exit {times[-1]:.2f} s" if times else ""
            print(f"{name:15s} exit codes {dict(histogram)}{slowest}", flush=True)
            clean &= histogram == Counter({0: args.signals})
            if histogram != Counter({0: args.signals}):
                logs = Path(temp) / "logs" / name / f"{name}.log"
                print(f"--- {logs} (last 40 lines)")
                print("\n".join(logs.read_text(errors="replace").splitlines()[-40:]))
    print("all clean" if clean else "NOT CLEAN: see above")
    return 0 if clean else 1


if __name__ == "__main__":
    sys.exit(main())
