"""The tracker registry: the tracker node's `method` parameter picks one of these (no rclpy).

Each method is a `tracker_msgs_py.registry.Method` whose `build(values, first_id)` returns a
`tracking.Tracker`; `values` holds the method's parameters by name. To add a tracker, write its
module (a class satisfying `tracking.Tracker`, bookkeeping through `tracking.TrackBook`) and
register it here with one `TRACKERS.register(Method(...))` line -- or, from another package,
declare the Method as an entry point in the `tracker_suite.trackers` group. The contract every
registered tracker must keep is checked by tests/filter/test_tracker_contract.py.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from tracker_filter.byte_tracker import METHOD as BYTE
from tracker_filter.config import PRESETS, TRACKING_PARAMETERS, TrackerConfig
from tracker_filter.gmphd_tracker import METHOD as GM_PHD
from tracker_filter.occupancy_tracker import METHOD as OCCUPANCY_PARTICLES
from tracker_filter.particle_tracker import METHOD as COLOUR_PARTICLES
from tracker_filter.selection import SELECTION_DEFAULTS
from tracker_filter.tracking import Tracker
from tracker_msgs_py.registry import Method, Registry

TRACKERS: Registry[Tracker] = Registry("tracker")
#: Entry-point group other packages declare their tracker `Method`s in (loaded by the node).
PLUGIN_GROUP = "tracker_suite.trackers"


def _gated_hungarian(values: Mapping[str, Any], first_id: int = 1) -> Tracker:
    return TrackerConfig.from_params({**SELECTION_DEFAULTS, **values}).build_tracker(first_id)


TRACKERS.register(
    Method(
        name="gated_hungarian",
        description="per-track alpha-beta / Kalman filters, chi-square gating, Hungarian "
        "assignment, M-of-N confirmation, deletion after consecutive misses (seed 000)",
        build=_gated_hungarian,
        parameters=TRACKING_PARAMETERS,
        presets=PRESETS,  # they also set the target selection for the node
    )
)
TRACKERS.register(COLOUR_PARTICLES)
TRACKERS.register(GM_PHD)
TRACKERS.register(OCCUPANCY_PARTICLES)
TRACKERS.register(BYTE)
