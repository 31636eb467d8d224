"""The benchmark of record on its small-object scene (seed 004), in process on a short clip: the
scene is rendered once and cached, the `gmphd` configuration runs only on small-object scenes,
and the table and results.json carry the scores on box centres."""

from __future__ import annotations

import json
import signal
import subprocess

import pytest
from ros_process import executable

pytest.importorskip("rclpy")  # the benchmark runs the graph's nodes, in process or not

from tracker_ptz_sim.bringup import benchmark
from tracker_ptz_sim.evaluation import error_classes


def test_the_small_object_scene_is_cached_and_its_configurations_paired(tmp_path, capsys):
    config = benchmark.SMALL_OBJECT_PRESETS["small_objects"]
    short = type(config)(num_frames=3, num_objects=4, crossings=1, seed=config.seed)
    first = benchmark.prepare_scene("small_objects", short, None, tmp_path)
    assert benchmark.prepare_scene("small_objects", short, None, tmp_path) == first
    assert capsys.readouterr().out.count("rendering") == 1
    assert benchmark.scene_kind(config) == benchmark.SMALL_OBJECTS
    assert benchmark.CONFIGURATIONS["gmphd"].graph == "small_objects"
    with pytest.raises(SystemExit):  # no street configuration runs on a small-object scene
        benchmark.main(["--scenes", "small_objects", "--configs", "suite", "--out", str(tmp_path)])


def test_a_short_gmphd_run_reports_ospa_and_centre_mota(tmp_path):
    out = tmp_path / "bench"
    argv = ["--scenes", "small_objects", "--configs", "gmphd", "--frames", "40", "--seeds", "1"]
    assert benchmark.main([*argv, "--out", str(out)]) == 0
    (result,) = json.loads((out / "results.json").read_text())
    assert (result["scene"], result["configuration"], result["path"]) == (
        "small_objects",
        "gmphd",
        "in-process",
    )
    centres = result["scores"]["centres"]
    assert {"ospa_5px", "ospa_10px", "mota", "idf1", "missed_occlusions"} <= centres.keys()
    assert 0.0 <= centres["ospa_5px"] <= 5.0 and 0.0 <= centres["ospa_10px"] <= 10.0
    assert centres["mota"] > 0.3  # tracks on many movers even in a 40-frame clip
    table = (out / "table.md").read_text()
    assert "| centre MOTA | centre IDF1 |" in table and "OSPA c=10 px" in table
    assert "| small_objects | gmphd | in-process | 1 |" in table
    # every miss and false box of the run in one class
    errors = result["scores"]["errors_in_view"]
    misses = sum(errors[n] for n in error_classes.MISSES)
    false = sum(errors[n] for n in error_classes.FALSE_POSITIVES)
    assert errors["people"] > 0 and 0 <= misses <= errors["people"]
    assert 0 <= false <= errors["reported"]
    assert (
        "Why boxes missed, in view" in table and "| misses: shared box | tentative track |" in table
    )


def test_ctrl_c_ends_the_benchmark_with_the_table_of_what_was_measured(tmp_path):
    """The in-process runs compute without polling a flag: Ctrl-C must still end the tool (it
    was ignored until the end), with the finished runs in table.md and exit code 130."""
    out = tmp_path / "bench"
    argv = ["--scenes", "small_objects", "--configs", "gmphd", "--frames", "30", "--seeds", "6"]
    process = subprocess.Popen(
        [executable("tracker_ptz_sim", "benchmark"), *argv, "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        for line in process.stdout:
            if line.startswith("  in view"):  # the first run's scores: five scenes to go
                process.send_signal(signal.SIGINT)
                break
        stdout, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr
    table = (out / "table.md").read_text()
    assert "Interrupted by SIGINT after 1 runs: the table is partial." in table
    assert "| small_objects | gmphd | in-process | 1 |" in table
