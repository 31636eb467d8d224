"""The detector registry: the detector node's `method` parameter picks one of these (no rclpy).

Each method is a `tracker_msgs_py.registry.Method` whose `build(values)` returns a
`detector.Detector`, exported as `METHOD` by the method's own module, its parameters the fields of
its config dataclass. To add a detector, write its module (a class satisfying `detector.Detector`
and a `METHOD = Method.of(...)`) and register it here with one line -- or, from another package,
declare the Method as an entry point in the `tracker_suite.detectors` group. The contract every
registered detector keeps is checked by tests/detect/test_detector_contract.py.
"""

from __future__ import annotations

from tracker_detect.background.background import METHOD as SSIM_BACKGROUND
from tracker_detect.camshift.camshift import METHOD as CAMSHIFT
from tracker_detect.detector import Detector
from tracker_detect.mog2.mog2 import METHOD as MOG2
from tracker_detect.motion.motion import METHOD as SSIM
from tracker_detect.person.fusion import METHOD as PERSON_MOTION
from tracker_detect.person.person import METHOD as PERSON
from tracker_msgs_py.registry import Registry

DETECTORS: Registry[Detector] = Registry("detector")
#: Entry-point group other packages declare their detector `Method`s in (loaded by the node).
PLUGIN_GROUP = "tracker_suite.detectors"

for _method in (SSIM, SSIM_BACKGROUND, CAMSHIFT, MOG2, PERSON, PERSON_MOTION):
    DETECTORS.register(_method)
