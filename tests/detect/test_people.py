"""Telling people apart inside one blob with the HOG people detector (tracker_detect.people)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from tracker_detect.detector import Blob
from tracker_detect.motion import find_blobs
from tracker_detect.people import (
    HOLD_FRAMES,
    PeopleDetector,
    PeopleSplitter,
    Person,
    _apart,
    _suppress,
)
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.simulation.street import StreetConfig, generate_street

CLEAN = dict(noise_sigma=0.0, jpeg_quality=0, optical_blur=0.0, illumination_drift=0.0)
QUIET = dict(flutter=0, foliage=0, flicker=0)


def street(**values) -> object:
    return generate_street(StreetConfig(num_frames=60, **(CLEAN | QUIET | values)))


def truth_blobs(scene, k: int):
    """Frame k's blobs as a perfect foreground mask makes them, and that mask."""
    mask = (scene.labels[k] > 0).astype(np.uint8)
    height, width = mask.shape
    view = View.identity(width, height)
    return find_blobs(mask, np.zeros(mask.shape, np.float32), view, 8), mask, view


def people_in(scene, k: int) -> list[Rect]:
    return [Rect(b.x, b.y, b.width, b.height) for b in scene.boxes[k]]


def test_a_hit_nested_in_a_stronger_one_or_overlapping_it_is_the_same_person():
    person = Person(Rect(100, 50, 40, 120), 2.0)
    legs = Person(Rect(105, 110, 30, 60), 1.0)  # all inside: a second hit on the legs
    shifted = Person(Rect(108, 52, 40, 120), 0.8)  # IoU 0.67: the same person again
    behind = Person(Rect(125, 40, 38, 115), 1.5)  # a person half behind: IoU ~0.27
    kept = _suppress([legs, shifted, person, behind])
    assert kept == [person, behind]


def test_hits_of_equal_margin_are_suppressed_the_same_whatever_their_order():
    """OpenCV hands the pyramid levels' hits back in the order its threads finish: two windows
    of one margin (the same content at two levels) must not leave the choice to that order."""
    small = Person(Rect(100, 64, 46, 138), 1.5)
    large = Person(Rect(104, 64, 50, 152), 1.5)  # nested in part: the same person, one level up
    other = Person(Rect(160, 60, 40, 120), 1.2)
    assert _suppress([small, large, other]) == _suppress([other, large, small]) == [small, other]


def test_people_in_one_blob_stand_apart_across():
    left = Person(Rect(100, 50, 40, 120), 1.0)
    beside = Person(Rect(122, 50, 40, 120), 1.0)  # centres 22 px apart: over half a width
    stride = Person(Rect(112, 50, 40, 120), 1.0)  # 12 px: one walker's stride or arm
    assert _apart([beside, left])
    assert not _apart([left, stride])


@pytest.fixture(scope="module")
def group():
    """Two people walking together across the view, one half behind the other (seed 2)."""
    return street(walkers=0, groups=1, seed=2)


def test_a_blob_over_two_people_is_split_into_them(group):
    splitter = PeopleSplitter()
    merged = recovered = pieces = pieces_on_people = 0
    for k in range(group.num_frames):
        blobs, mask, view = truth_blobs(group, k)
        truth = people_in(group, k)
        out = splitter.split(blobs, group.frames[k], mask, view)
        new = [b for b in out if b not in blobs]
        pieces += len(new)
        pieces_on_people += sum(max(b.bbox.iou(t) for t in truth) >= 0.5 for b in new)
        for blob in blobs:
            held = [t for t in truth if _inside(t, blob.bbox) >= 0.5]
            if len(held) >= 2 and max(blob.bbox.iou(t) for t in held) < 0.5:
                merged += 1
                recovered += all(any(b.bbox.iou(t) >= 0.5 for b in out) for t in held)
    assert merged >= 15
    # 5 of 19 here (OpenCV 5.0), 3 with OpenCV 4.11: the one half behind is often not found
    assert recovered >= 3, f"{recovered} of {merged} merged blobs split into their people"
    assert pieces_on_people >= 0.8 * pieces > 0


def test_people_walking_alone_are_never_split():
    splitter = PeopleSplitter()
    scene = street(walkers=4, seed=1)
    for k in range(scene.num_frames):
        blobs, mask, view = truth_blobs(scene, k)
        assert splitter.split(blobs, scene.frames[k], mask, view) == blobs, k


def test_a_split_is_held_while_hog_misses_its_people_then_let_go(group):
    splitter = PeopleSplitter()
    for k in range(group.num_frames):
        blobs, mask, view = truth_blobs(group, k)
        out = splitter.split(blobs, group.frames[k], mask, view)
        if len(out) > len(blobs):
            break
    else:
        pytest.fail("no split in the group scene")
    blank = np.full_like(group.frames[k], 128)  # nothing for HOG to find
    for _ in range(HOLD_FRAMES):
        assert splitter.split(blobs, blank, mask, view) == out
    assert splitter.split(blobs, blank, mask, view) == blobs
    splitter.reset()
    assert splitter.split(blobs, blank, mask, view) == blobs


def test_a_pair_one_behind_the_other_as_narrow_as_one_walker_is_split():
    """A blob the surveillance graph's detector made of two people walking one half behind the
    other (benchmark scene groups-14, frame 21, the camera's view around it): 0.39 as wide as
    tall, as narrow as many single walkers, yet HOG finds both and each gets their own piece."""
    data = np.load(Path(__file__).parent / "data" / "pair_one_behind_the_other.npz")
    image = cv2.imdecode(data["image_jpeg"], cv2.IMREAD_COLOR)
    shape = tuple(data["mask_shape"])
    mask = np.unpackbits(data["mask_bits"], count=int(np.prod(shape))).reshape(shape)
    box = Rect(*(float(v) for v in data["blob_box"]))
    people = [Rect(*(float(v) for v in row)) for row in data["people"]]
    ys, xs = np.nonzero(mask)
    blob = Blob(float(xs.mean()) + 0.5, float(ys.mean()) + 0.5, box, len(xs), len(xs), 0.0)
    assert box.width < 0.4 * box.height
    view = View.identity(shape[1], shape[0])
    pieces = PeopleSplitter().split([blob], image, mask, view)
    assert len(pieces) == 2
    for person in people:
        assert max(piece.bbox.iou(person) for piece in pieces) >= 0.5


def _inside(person: Rect, box: Rect) -> float:
    """Share of `person`'s box inside `box`."""
    return person.intersection_area(box) / person.area


def test_the_levels_on_two_threads_find_what_one_thread_finds(group):
    """The pyramid's levels shared with a worker thread give the same hits in the same order."""
    one, two = PeopleDetector(threads=1), PeopleDetector(threads=2)
    found = 0
    for k in range(0, group.num_frames, 3):
        for box in people_in(group, k):
            region = Rect(box.x - 40, box.y - 40, box.width + 80, box.height + 80)
            heights = (0.6 * box.height, 1.1 * box.height)
            alone = one.find(group.frames[k], region, heights)
            assert two.find(group.frames[k], region, heights) == alone, k
            found += len(alone)
    assert found > 0
    with pytest.raises(ValueError, match="threads"):
        PeopleDetector(threads=3)
