"""/diagnostics from a node: its state and, per input topic, the message rate, the callback's time
and the data's age on arrival, besides the dropped input; per published topic, the readers its
publisher has matched."""

from __future__ import annotations

import pytest

from tracker_msgs_py.node_stats import InputStats


def test_input_stats_report_a_period_and_start_the_next():
    stats = InputStats()
    for processing_s, age_s in [(0.002, 0.010), (0.004, None), (0.003, 0.030)]:
        stats.record(processing_s, age_s)
    assert dict(stats.report("/camera/image_raw", period_s=0.5)) == {
        "/camera/image_raw rate [Hz]": "6.00",
        "/camera/image_raw received": "3",
        "/camera/image_raw processing mean/max [ms]": "3.00/4.00",
        "/camera/image_raw age on arrival mean [ms]": "20.0",
    }
    assert dict(stats.report("/camera/image_raw", period_s=1.0)) == {
        "/camera/image_raw rate [Hz]": "0.00",
        "/camera/image_raw received": "3",
    }
    assert stats.busy_s == pytest.approx(0.009)  # since the start, not per period


def test_the_controller_reports_its_state_and_its_inputs():
    pytest.importorskip("rclpy")
    from diagnostic_msgs.msg import DiagnosticArray
    from node_harness import NodeHarness
    from ptz_messages import state_msg, target_msg

    from tracker_msgs.msg import PtzState, Target
    from tracker_msgs_py.node_main import callback_load, matched_readers, matched_writers
    from tracker_ptz_sim.control.ptz_controller_node import PtzControllerNode

    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"/diagnostics": (DiagnosticArray, 10)},
    )
    try:
        for frame in range(5):
            h.publish("ptz/state", state_msg(frame * 100_000_000))
            h.publish("target", target_msg(frame * 100_000_000))
            h.spin_for(0.02)

        def report():
            for array in h.received["/diagnostics"]:
                inputs = {s.name: s for s in array.status}.get("/ptz_controller: input")
                if inputs and any(
                    v.key == "/target received" and v.value == "5" for v in inputs.values
                ):
                    return array
            return None

        h.spin_until(lambda: report() is not None, timeout=5.0)
        statuses = {s.name: s for s in report().status}
        assert statuses["/ptz_controller: state"].message == "track"
        values = {v.key: v.value for v in statuses["/ptz_controller: input"].values}
        assert {"/target rate [Hz]", "/ptz/state processing mean/max [ms]"} <= values.keys()
        assert "/target age on arrival mean [ms]" in values
        # Its publishers' own matched readers: this test reads /diagnostics, nothing ptz/command.
        readers = matched_readers(next(a for a in h.received["/diagnostics"] if a.status))
        assert readers["/diagnostics"] == 1 and readers["/ptz/command"] == 0
        # ... and its readers' matched writers: the test publishes both of its inputs.
        writers = matched_writers(next(a for a in h.received["/diagnostics"] if a.status))
        assert writers["/ptz_controller"]["/target"] == 1
        assert writers["/ptz_controller"]["/ptz/state"] == 1
        # ... and its time in callbacks since the start, with the messages of the same moment
        load = callback_load(report())["/ptz_controller"]
        assert load.received["/target"] == 5 and load.received["/ptz/state"] == 5
        assert 0 < load.busy_s < 5.0
        assert load.per_message("/target") == pytest.approx(load.busy_s / 5)
        assert load.per_message("/not/an/input") is None
    finally:
        h.close()


def test_levels_say_when_a_node_cannot_work_and_when_an_input_went_silent():
    """Targets but never a pan-tilt state: the controller's state is ERROR (it cannot steer),
    named with the unit's hardware_id; once the targets stop, its input status turns WARN."""
    pytest.importorskip("rclpy")
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from node_harness import NodeHarness
    from ptz_messages import target_msg

    from tracker_msgs.msg import PtzState, Target
    from tracker_msgs_py.node_main import INPUT_SILENCE_S
    from tracker_ptz_sim.control.ptz_controller_node import PtzControllerNode

    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"/diagnostics": (DiagnosticArray, 50)},
    )
    try:
        for frame in range(3):
            h.feed("target", target_msg(frame * 100_000_000))

        def latest(suffix):
            for array in reversed(h.received["/diagnostics"]):
                found = {s.name: s for s in array.status}.get(f"/ptz_controller{suffix}")
                if found is not None:
                    return found
            return None

        h.spin_until(lambda: latest(": state") is not None, timeout=5.0)
        state = latest(": state")
        assert state.level == DiagnosticStatus.ERROR and "no usable ptz/state" in state.message
        assert state.hardware_id == "ptz"
        h.spin_until(
            lambda: (
                "no message on /target" in (latest(": input").message if latest(": input") else "")
            ),
            timeout=INPUT_SILENCE_S + 3.0,
        )
        assert latest(": input").level == DiagnosticStatus.WARN
    finally:
        h.close()
