"""The surveillance graph split over two hosts, and the latency the hop adds.

    sudo -E python scripts/two_hosts.py [--video PATH] [--out out/two_hosts]   (needs root: netns)

Two Linux network namespaces joined by a veth pair stand for two machines on one subnet (their own
interfaces, addresses and routes; DDS discovery by multicast on the subnet, with the peer's address
as a static peer too, not localhost-only). Host A (10.211.0.1) runs the camera side: video_source,
ptz_camera, ssim_detector and the recorder (`run_demo --external tracker --external
ptz_controller`); host B (10.211.0.2) runs tracker and ptz_controller. Then the same graph runs on
host A alone. Both runs use Fast DDS over UDP only (shared memory would cross the namespaces
unseen), in lockstep, so both must give the same tracks; the recorder's receive times give each
hop's latency as the run report has it.

The detector -> tracker hop is also timed exactly, by a probe on host A that takes the middleware's
times: from the detections' publication (their source timestamp) to the arrival of the target of
the same image stamp (its reception timestamp). Both are taken on host A's clock and the second
follows the first causally, so the figure is never negative; the recorder's callback times are not
(the recorder, the busiest process, runs up to milliseconds behind and a sub-millisecond hop came
out negative). The split run's probed hop (out to B and back) minus the single-host one is what the
two crossings of the link add. The probe spins a SingleThreadedExecutor: rclpy's EventsExecutor in
Jazzy fails on callbacks that take the message info (SystemError).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path

from tracker_ptz_sim.bringup.graph import executable_path, load_graph, ros_args
from tracker_ptz_sim.evaluation import metrics
from tracker_ptz_sim.evaluation.run_report import DETECTIONS, TARGET, latency_stats

HOSTS = {"a": "10.211.0.1", "b": "10.211.0.2"}
REMOTE_NODES = ("tracker", "ptz_controller")
HOP = "ssim_detector -> tracker"
PROBED = {DETECTIONS: "source_timestamp", TARGET: "received_timestamp"}
PROBE_START_S = 60.0  # for the probe process to create its readers
INSTALL = Path(__file__).resolve().parents[1] / "install"


def sh(*command: str) -> None:
    subprocess.run(command, check=True, capture_output=True, text=True)


@contextmanager
def two_hosts(tag: str) -> Iterator[dict[str, str]]:
    """Network namespaces `<tag>a`, `<tag>b` joined by a veth pair; removed on exit."""
    names = {host: f"{tag}{host}" for host in HOSTS}
    try:
        for name in names.values():
            sh("ip", "netns", "add", name)
        sh("ip", "link", "add", f"{tag}va", "type", "veth", "peer", "name", f"{tag}vb")
        for host, name in names.items():
            link = f"{tag}v{host}"
            sh("ip", "link", "set", link, "netns", name)
            inside = ["ip", "netns", "exec", name]
            sh(*inside, "ip", "addr", "add", f"{HOSTS[host]}/24", "dev", link)
            sh(*inside, "ip", "link", "set", link, "up", "multicast", "on")
            sh(*inside, "ip", "link", "set", "lo", "up")
            sh(*inside, "ip", "route", "add", "224.0.0.0/4", "dev", link)
        yield names
    finally:
        for name in names.values():
            subprocess.run(["ip", "netns", "del", name], capture_output=True)


def environment(peer: str) -> dict[str, str]:
    """DDS between the hosts over UDP: discovery on the subnet, the other host as a peer."""
    return {
        **os.environ,
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET",
        "ROS_STATIC_PEERS": peer,
        "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
    }


def run_demo(netns: str, video: Path, out: Path, env: dict[str, str], *extra: str) -> dict:
    command = [
        "ip",
        "netns",
        "exec",
        netns,
        str(INSTALL / "tracker_ptz_sim/lib/tracker_ptz_sim/run_demo"),
    ]
    command += ["--video", str(video), "--out", str(out), "--no-video", *extra]
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=900)
    if result.returncode != 0:
        raise RuntimeError(f"run_demo in {netns} failed:\n{result.stdout}\n{result.stderr}")
    return json.loads((out / "summary.json").read_text())


def probe(out: Path) -> int:
    """Until SIGINT: per image stamp, the detections' publication time and the target's arrival
    time on this host (ns), written to `out` as JSON."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from tracker_msgs_py.codec import header_stamp_ns, result_qos
    from tracker_ptz_sim.bringup.demo import import_message_type

    rclpy.init(args=["--ros-args", "--disable-rosout-logs"])
    node = rclpy.create_node("hop_probe")
    times: dict[str, dict[int, int]] = {topic: {} for topic in PROBED}
    types = {topic.name: topic.type for topic in load_graph().topics}

    def keep(topic: str, data: bytes, info: dict[str, int]) -> None:
        times[topic].setdefault(header_stamp_ns(data), info[PROBED[topic]])

    for topic in PROBED:
        node.create_subscription(
            import_message_type(types[topic]),
            topic,
            partial(keep, topic),
            result_qos(False),
            raw=True,
        )
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = []
    signal.signal(signal.SIGINT, lambda *_: stop.append(True))
    executor.spin_once(timeout_sec=0.0)
    ready_file(out).touch()  # its readers exist: the graph may start
    while not stop:
        executor.spin_once(timeout_sec=0.1)
    rows = {
        str(stamp): [sent, times[TARGET].get(stamp)] for stamp, sent in times[DETECTIONS].items()
    }
    out.write_text(json.dumps(rows))
    return 0


def probed_latency_ms(path: Path) -> dict[str, float]:
    """The frames the probe timed, and min, p50, p95 and max of their detections -> target times
    (ms)."""
    rows = json.loads(path.read_text()).values()
    values = [(arrived - sent) / 1e6 for sent, arrived in rows if arrived is not None]
    if not values:
        raise RuntimeError(f"the probe ({path}) saw no detections with their target")
    return {"frames": len(values), **latency_stats(values)}


def ready_file(out: Path) -> Path:
    """The file the probe writing `out` creates once its readers exist."""
    return out.with_name(out.name + ".ready")


@contextmanager
def probing(netns: str, env: dict[str, str], out: Path) -> Iterator[Path]:
    """The probe running in `netns` for the duration; yields the JSON it writes on exit. The
    graph starts only once the probe's readers exist (a fixed second was not always enough on a
    loaded machine: the probe's own start-up took longer and it missed the first frames); the
    graph's nodes then take seconds to come up and reach their first frame, time for the probe's
    readers to match their writers."""
    ready = ready_file(out)
    ready.unlink(missing_ok=True)
    command = ["ip", "netns", "exec", netns, sys.executable, __file__, "--probe", str(out)]
    process = subprocess.Popen(command, env=env)
    deadline = time.monotonic() + PROBE_START_S
    while not ready.exists():
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            raise RuntimeError(f"the hop probe did not start within {PROBE_START_S:.0f} s")
        time.sleep(0.05)
    try:
        yield out
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--video", type=Path, help="default: vtest.avi from the sample cache")
    parser.add_argument("--out", type=Path, default=Path("out/two_hosts"))
    parser.add_argument("--probe", type=Path, help=argparse.SUPPRESS)  # the probe's own process
    args = parser.parse_args(argv)
    if args.probe:
        return probe(args.probe)
    if os.geteuid() != 0:
        print(
            "needs root (network namespaces): sudo -E python scripts/two_hosts.py", file=sys.stderr
        )
        return 2
    video = args.video or Path.home() / ".cache/tracker_suite/vtest.avi"
    graph = load_graph()
    args.out.mkdir(parents=True, exist_ok=True)
    tag = f"ts{os.getpid() % 10000}"
    with two_hosts(tag) as netns:
        remote = []
        env_b = environment(HOSTS["a"])
        try:
            for name in REMOTE_NODES:
                node = graph.node(name)
                command = ["ip", "netns", "exec", netns["b"], str(executable_path(INSTALL, node))]
                command += ros_args(node, graph.params_files)
                log = (args.out / f"host_b_{name}.log").open("w")
                remote.append(
                    subprocess.Popen(command, env=env_b, stdout=log, stderr=subprocess.STDOUT)
                )
            externals = [arg for name in REMOTE_NODES for arg in ("--external", name)]
            env_a = environment(HOSTS["b"])
            with probing(netns["a"], env_a, args.out / "split_probe.json") as split_probe:
                split = run_demo(netns["a"], video, args.out / "split", env_a, *externals)
        finally:
            for process in remote:
                process.send_signal(2)
            for process in remote:
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
        env_a = environment(HOSTS["a"])
        with probing(netns["a"], env_a, args.out / "single_probe.json") as single_probe:
            single = run_demo(netns["a"], video, args.out / "single", env_a)
    probed = {
        "two hosts": probed_latency_ms(split_probe),
        "one host": probed_latency_ms(single_probe),
    }
    same = metrics.load_mot(args.out / "split/tracks.txt") == metrics.load_mot(
        args.out / "single/tracks.txt"
    )
    report = {
        "frames": [split["frames"], single["frames"]],
        "same_tracks": same,
        "latency_ms": {"two hosts": split["latency_ms"], "one host": single["latency_ms"]},
        "throughput_fps": {
            "two hosts": split["throughput_fps"],
            "one host": single["throughput_fps"],
        },
        "probed_hop_ms": probed,
        "hop_added_ms_p50": probed["two hosts"]["p50"] - probed["one host"]["p50"],
        # the fastest frame of each run: the link's own cost, least disturbed by the load
        "hop_added_ms_min": probed["two hosts"]["min"] - probed["one host"]["min"],
    }
    (args.out / "two_hosts.json").write_text(json.dumps(report, indent=2))
    print(f"{'':40}{'two hosts':>12}{'one host':>12}")
    for hop in split["latency_ms"]:
        a, b = (
            split["latency_ms"][hop]["p50"],
            single["latency_ms"].get(hop, {}).get("p50", float("nan")),
        )
        print(f"{hop + ' p50 [ms]':40}{a:12.2f}{b:12.2f}")
    print(
        f"{'throughput [frames/s]':40}{split['throughput_fps']:12.1f}{single['throughput_fps']:12.1f}"
    )
    a, b = probed["two hosts"]["p50"], probed["one host"]["p50"]
    print(f"{'probed ' + HOP + ' p50 [ms]':40}{a:12.2f}{b:12.2f}")
    print(
        f"identical tracks: {same}; the probed hop ({HOP}: out to host B and back) adds "
        f"{report['hop_added_ms_p50']:.2f} ms (p50), {report['hop_added_ms_min']:.2f} ms (fastest frames)"
    )
    return 0 if same and split["run"]["complete"] and single["run"]["complete"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
