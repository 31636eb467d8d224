"""Real people in street scenes: cut-outs from a clip, the development / held-out split, and ground
truth that is exactly where the cut-outs were pasted."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from tracker_ptz_sim.simulation import real_people, street
from tracker_ptz_sim.simulation.ground_truth import Box, Tracks
from tracker_ptz_sim.simulation.real_people import CutoutConfig, CutoutLibrary, Run, Sprite

GREY = (128, 128, 128)


def figure_mask(h: int, w: int) -> np.ndarray:
    """A person-like shape: a head over a body, filling about half of its box."""
    mask = np.zeros((h, w), np.uint8)
    cv2.circle(mask, (w // 2, h // 8), max(2, h // 9), 1, -1)
    cv2.ellipse(mask, (w // 2, h // 2 + h // 10), (w // 2 - 1, int(h * 0.38)), 0, 0, 360, 1, -1)
    return mask


def test_a_cut_out_is_the_person_and_not_the_ground():
    background = np.full((240, 320, 3), GREY, np.uint8)
    frame = background.copy()
    shape = figure_mask(80, 30)
    frame[100:180, 150:180][shape > 0] = (40, 30, 160)
    sprite = real_people.cut_out(frame, background, Box(150, 100, 30, 80), CutoutConfig())
    assert sprite is not None
    h, w = sprite.alpha.shape
    found = sprite.alpha >= 0.5
    truth = np.zeros((h, w), bool)
    ox, oy = 150 - math.floor(150 - (0.15 * 30 + 2)), 100 - math.floor(100 - (0.04 * 80 + 2))
    truth[oy : oy + 80, ox : ox + 30] = shape > 0
    iou = (found & truth).sum() / (found | truth).sum()
    assert iou > 0.9
    assert sprite.height == 80 and sprite.foot == (ox + 15, oy + 80)


def test_people_walking_together_are_not_cut_out():
    frames = [np.full((240, 320, 3), GREY, np.uint8) for _ in range(20)]
    truth = Tracks(
        {
            1: {f: Box(100 + f, 50, 30, 80) for f in range(1, 21)},
            2: {f: Box(128 + f, 50, 30, 80) for f in range(1, 21)},  # beside person 1
            3: {f: Box(250 - f, 140, 30, 80) for f in range(1, 21)},
        }
    )
    for k, frame in enumerate(frames):
        for boxes in truth.in_frame(k + 1).values():
            x, y = round(boxes.x), round(boxes.y)
            frame[y : y + 80, x : x + 30][figure_mask(80, 30) > 0] = (20, 20, 20)
    background = np.full((240, 320, 3), GREY, np.uint8)
    library = real_people.build_library(frames, background, truth, CutoutConfig())
    assert [r.person for r in library.runs] == [3]
    run = library.runs[0]
    assert len(run.sprites) == 20 and run.direction == -1.0
    assert abs(run.stride - 1 / 80) < 1e-6  # 1 px a frame for an 80 px person


def test_every_third_person_is_held_out_and_the_sets_are_disjoint():
    sets = real_people.split([9, 2, 4, 7, 11, 5])
    assert sets["held_out"] == {5, 11}
    assert sets["development"] == {2, 4, 7, 9}


def person_colour(person: int) -> tuple[int, int, int]:
    """A red-heavy colour of its own per person: red 255 (the labels test reads it), blue and
    green apart."""
    return (40 * (person % 5), 60 * (person // 5) + 20 * (person % 2), 255)


def synthetic_library(people: int) -> CutoutLibrary:
    """Cut-outs of solid figures, hard-edged (alpha 0 or 1), each person's own colour."""
    runs = []
    for person in range(1, people + 1):
        colour = np.zeros((90, 34, 3), np.uint8)
        colour[:] = person_colour(person)
        sprites = []
        for k in range(12):
            alpha = figure_mask(86, 30).astype(np.float32)
            alpha = np.pad(alpha, ((2, 2), (2, 2)))
            alpha[60:88, 2 + k % 3 : 8] = 1.0  # a leg that swings: the frames differ
            sprites.append(Sprite(colour, alpha, (17.0, 88.0), 86.0))
        runs.append(Run(person, 1, sprites, 1.0 if person % 2 else -1.0, 0.02))
    return CutoutLibrary(runs)


def test_ground_truth_boxes_are_the_pasted_cut_outs():
    config = replace(
        street.REAL_PEOPLE_PRESETS["real_walkers"],
        num_frames=60,
        flutter=0,
        foliage=0,
        flicker=0,
        shadow=0.0,
        illumination_drift=0.0,
        optical_blur=0.0,
        noise_sigma=0.0,
        jpeg_quality=0,
        seed=3,
    )
    background = np.full((config.height, config.width, 3), GREY, np.uint8)
    scene = street.generate_street(config, background, synthetic_library(9))
    checked = 0
    for n in range(config.num_frames):
        # every cut-out is red 255 over grey 128, blended by its alpha: alpha >= 0.5 where red
        # is at least 128 + 127 / 2 (give or take a grey level of rounding)
        red, labelled = scene.frames[n][:, :, 2], scene.labels[n] > 0
        assert labelled[red >= 193].all() and not labelled[red <= 190].any()
        for box in scene.boxes[n]:
            mine = scene.labels[n] == box.object_id
            rows, cols = np.flatnonzero(mine.any(axis=1)), np.flatnonzero(mine.any(axis=0))
            assert (box.x, box.y) == (cols[0], rows[0])
            assert (box.width, box.height) == (cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1)
            checked += 1
    assert checked > 100
    people = {box.object_id for boxes in scene.boxes for box in boxes}
    assert len(people) >= 4


def test_held_out_scenes_show_only_held_out_people():
    library = synthetic_library(9)
    config = replace(street.REAL_PEOPLE_PRESETS["heldout_walkers"], num_frames=40)
    background = np.full((config.height, config.width, 3), GREY, np.uint8)
    scene = street.generate_street(config, background, library)
    held = real_people.split(library.people())["held_out"]
    grey = np.array(GREY, float)
    checked = 0
    for n in (10, 20, 30):
        for box in scene.boxes[n]:
            pixels = scene.frames[n][scene.labels[n] == box.object_id].astype(float)
            if len(pixels) < 100:
                continue
            # blended over grey and through JPEG, a person's pixels still point from grey
            # towards their cut-out's colour: the nearest direction names the cut-out
            towards = pixels.mean(axis=0) - grey
            nearest = max(
                library.people(),
                key=lambda p: float(
                    np.dot(towards, np.array(person_colour(p)) - grey)
                    / np.linalg.norm(np.array(person_colour(p)) - grey)
                    / np.linalg.norm(towards)
                ),
            )
            assert nearest in held
            checked += 1
    assert checked >= 3
