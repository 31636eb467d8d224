"""Zones: detections in ignore zones are no measurements; with required zones the camera follows
only a track that has been in one; polygons parsed from Frigate's coordinate strings."""

from __future__ import annotations

import numpy as np
import pytest
from track_sets import L, track_set

from tracker_filter.observation import Detections
from tracker_filter.selection import SelectionPolicy, TargetSelector
from tracker_filter.zones import Zones, foot_points, parse_polygons

SQUARE = "0,0,100,0,100,100,0,100"


def test_polygons_parse_from_frigate_coordinates_and_bad_ones_are_named():
    square, triangle = parse_polygons(f"{SQUARE}; 200,0, 300,0, 250,80")
    assert square.contains(np.array([[50, 50], [150, 50], [-1, 50]])).tolist() == [
        True,
        False,
        False,
    ]
    assert triangle.contains(np.array([[250, 40], [210, 70]])).tolist() == [True, False]
    assert parse_polygons("") == () and parse_polygons(" ; ") == ()
    with pytest.raises(ValueError, match="ignore_zones: polygon 2 needs at least three"):
        parse_polygons(f"{SQUARE}; 1,2,3,4", "ignore_zones")
    with pytest.raises(ValueError, match="polygon 1 is not numbers"):
        parse_polygons("a,b,c,d,e,f")
    with pytest.raises(ValueError, match="finite"):
        parse_polygons("0,0,nan,0,1,1")


def test_a_concave_polygon_leaves_its_notch_out():
    (u_shape,) = parse_polygons("0,0,30,0,30,30,20,30,20,10,10,10,10,30,0,30")
    points = np.array([[5, 20], [15, 20], [25, 20], [15, 5]])
    assert u_shape.contains(points).tolist() == [True, False, True, True]


def test_detections_standing_in_an_ignore_zone_are_dropped_by_their_foot_point():
    zones = Zones(ignore=parse_polygons(SQUARE))
    # boxes x, y, w, h: the first stands in the square (foot 50, 90); the second's foot (50, 130)
    # is below it although its top half is inside; the third is far away
    boxes = np.array([[40, 40, 20, 50], [40, 80, 20, 50], [300, 300, 20, 50]], dtype=float)
    detections = Detections(boxes[:, :2] + boxes[:, 2:] / 2, np.full(3, 1000.0), boxes, np.ones(3))
    assert foot_points(boxes)[:2].tolist() == [[50, 90], [50, 130]]
    kept, dropped = zones.outside_ignored(detections)
    assert dropped == 1 and kept.bboxes[:, 1].tolist() == [80, 300]
    assert Zones().outside_ignored(detections) == (detections, 0)


def test_with_a_required_zone_only_a_track_that_has_been_in_it_is_followed():
    zones = Zones(required=parse_polygons(SQUARE))
    selector = TargetSelector(SelectionPolicy.LONGEST_LIVED, min_lock_time=0.0)
    # track 1 is older (would win) but never enters; track 2 walks into the square at t = 1
    outside = track_set(0.0, [1, 2], [[300, 50], [150, 45]], ages=[9, 1])
    assert selector.update(outside, allowed=zones.followable(outside)) is None
    inside = track_set(1.0, [1, 2], [[300, 50], [50, 45]], ages=[10, 2])
    assert selector.update(inside, allowed=zones.followable(inside)).track_id == 2
    left = track_set(2.0, [1, 2], [[300, 50], [150, 45]], ages=[11, 3])  # it walks out again
    assert zones.followable(left).tolist() == [False, True]  # once in, always followable
    assert selector.update(left, allowed=zones.followable(left)).track_id == 2
    gone = track_set(3.0, [1, 2], [[300, 50], [150, 45]], status=[1, L])
    zones.followable(gone)
    assert zones.entered == set()  # a lost track is forgotten
    assert Zones().followable(gone) is None  # no required zone: every track
