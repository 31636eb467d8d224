"""The surveillance graph split over two hosts, and the latency the hop adds.

    sudo -E python scripts/two_hosts.py [--video PATH] [--out out/two_hosts]   (needs root: netns)

Two Linux network namespaces joined by a veth pair stand for two machines on one subnet (their own
interfaces, addresses and routes; DDS discovery by multicast on the subnet, with the peer's address
as a static peer too, not localhost-only). Host A (10.211.0.1) runs the camera side: video_source,
ptz_camera, ssim_detector and the recorder (`run_demo --external tracker --external
ptz_controller`); host B (10.211.0.2) runs tracker and ptz_controller. Then the same graph runs on
host A alone. Both runs use Fast DDS over UDP only (shared memory would cross the namespaces
unseen), in lockstep, so both must give the same tracks; the recorder's receive times give each
hop's latency, and the split run's detector -> tracker hop (detections to B, tracks back to A)
minus the single-host one is what the two crossings of the link add.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tracker_ptz_sim.bringup.graph import executable_path, load_graph, ros_args
from tracker_ptz_sim.evaluation import metrics

HOSTS = {"a": "10.211.0.1", "b": "10.211.0.2"}
REMOTE_NODES = ("tracker", "ptz_controller")
HOP = "ssim_detector -> tracker"
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--video", type=Path, help="default: vtest.avi from the sample cache")
    parser.add_argument("--out", type=Path, default=Path("out/two_hosts"))
    args = parser.parse_args(argv)
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
            split = run_demo(
                netns["a"], video, args.out / "split", environment(HOSTS["b"]), *externals
            )
        finally:
            for process in remote:
                process.send_signal(2)
            for process in remote:
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
        single = run_demo(netns["a"], video, args.out / "single", environment(HOSTS["a"]))
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
        "hop_added_ms_p50": split["latency_ms"][HOP]["p50"] - single["latency_ms"][HOP]["p50"],
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
    print(
        f"identical tracks: {same}; the hop ({HOP}: out to host B and back) adds "
        f"{report['hop_added_ms_p50']:.2f} ms (p50)"
    )
    return 0 if same and split["run"]["complete"] and single["run"]["complete"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
