"""Class labels of detections and tracks (no rclpy).

Every detection and track carries a label: what a classifier said it is (`PERSON` from the person
model), or `MOTION` for a region nothing classified (a motion or foreground blob, a colour region).
Target selection follows only the labels it is told (`track_labels`); `ANY_LABEL` there means
every label. The MOT output writes MOTChallenge's class id (1 = pedestrian, -1 = unknown).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

PERSON = "person"
MOTION = "motion"
ANY_LABEL = "any"  # a word, not "*": YAML reads a bare * as an alias
MOT_CLASS_IDS = {PERSON: 1}  # MOTChallenge's class ids; other labels are -1 (unknown)


def mot_class_id(label: str) -> int:
    return MOT_CLASS_IDS.get(label, -1)


def label_of(text: str) -> str:
    """A message's label: an empty one (a sender that sets none) is `MOTION`."""
    return str(text) or MOTION


def label_array(labels: Iterable[str] | None, count: int) -> np.ndarray:
    """(count,) object array of labels; `MOTION` for each when `labels` is None."""
    if labels is None:
        return np.full(count, MOTION, dtype=object)
    array = np.empty(count, dtype=object)
    values = [label_of(label) for label in labels]
    if len(values) != count:
        raise ValueError(f"{len(values)} labels for {count} detections")
    array[:] = values
    return array


def wanted(labels: np.ndarray, names: Iterable[str]) -> np.ndarray:
    """Mask of the `labels` among `names` (all of them when `names` holds `ANY_LABEL`)."""
    names = tuple(names)
    if ANY_LABEL in names:
        return np.ones(len(labels), dtype=bool)
    return np.isin(labels.astype(str), names) if len(labels) else np.zeros(0, dtype=bool)


def classified_over(current: np.ndarray, found: np.ndarray) -> np.ndarray:
    """Track labels after tracks labelled `current` took detections labelled `found`: a class
    sticks, `MOTION` does not overwrite it (a person whose box was missed for a frame and who was
    matched with a motion blob instead is still a person)."""
    return np.where(found == MOTION, current, found)
