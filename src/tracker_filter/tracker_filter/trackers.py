"""The tracker registry: the tracker node's `method` parameter picks one of these (no rclpy).

Each method is a `tracker_msgs_py.registry.Method` whose `build(values, first_id)` returns a
`tracking.Tracker`, exported as `METHOD` by the method's own module (`Method.of` its config
dataclass, whose `param` fields are its parameters). To add a tracker, write its module (a class
satisfying `tracking.Tracker`, bookkeeping through `tracking.TrackBook`, and its `METHOD`) and
register it here with one `TRACKERS.register(...)` line -- or, from another package,
declare the Method as an entry point in the `tracker_suite.trackers` group. The contract every
registered tracker must keep is checked by tests/filter/test_tracker_contract.py.
"""

from __future__ import annotations

from tracker_filter.byte.byte_tracker import METHOD as BYTE
from tracker_filter.gated_hungarian.config import METHOD as GATED_HUNGARIAN
from tracker_filter.gm_phd.gmphd_tracker import METHOD as GM_PHD
from tracker_filter.occupancy.occupancy_tracker import METHOD as OCCUPANCY_PARTICLES
from tracker_filter.particles.particle_tracker import METHOD as COLOUR_PARTICLES
from tracker_filter.tracking import Tracker
from tracker_msgs_py.registry import Registry

TRACKERS: Registry[Tracker] = Registry("tracker")
#: Entry-point group other packages declare their tracker `Method`s in (loaded by the node).
PLUGIN_GROUP = "tracker_suite.trackers"


TRACKERS.register(GATED_HUNGARIAN)
TRACKERS.register(COLOUR_PARTICLES)
TRACKERS.register(GM_PHD)
TRACKERS.register(OCCUPANCY_PARTICLES)
TRACKERS.register(BYTE)
