"""The recorder keeps one message per scene frame when video_source sends a frame once more."""

from tracker_ptz_sim.bringup.demo import REPEATED_TOPICS, SCENE_TOPIC, RepeatFilter


def test_a_frame_sent_again_is_a_repeat_on_its_topic_only() -> None:
    repeats = RepeatFilter(REPEATED_TOPICS, memory=4)
    assert not repeats.repeats(SCENE_TOPIC, 2_400_000_000)
    assert not repeats.repeats("/scene/camera_info", 2_400_000_000)  # its own topic: taken
    assert repeats.repeats(SCENE_TOPIC, 2_400_000_000)  # sent again after a late acknowledgement
    assert repeats.repeats("/scene/camera_info", 2_400_000_000)
    assert not repeats.repeats(SCENE_TOPIC, 2_500_000_000)  # the next frame


def test_topics_that_are_not_repeated_are_never_dropped() -> None:
    repeats = RepeatFilter(REPEATED_TOPICS, memory=4)
    assert not repeats.repeats("/tracks", 100)
    assert not repeats.repeats("/tracks", 100)


def test_the_memory_holds_the_newest_stamps() -> None:
    repeats = RepeatFilter([SCENE_TOPIC], memory=2)
    for stamp in (1, 2, 3):
        assert not repeats.repeats(SCENE_TOPIC, stamp)
    assert repeats.repeats(SCENE_TOPIC, 3) and repeats.repeats(SCENE_TOPIC, 2)
    assert not repeats.repeats(SCENE_TOPIC, 1)  # forgotten: a restarted source never goes back


def test_the_stamps_taken_are_kept_oldest_first_without_repeats() -> None:
    repeats = RepeatFilter([SCENE_TOPIC], memory=3)
    for stamp in (1, 2, 2, 3, 4):
        repeats.repeats(SCENE_TOPIC, stamp)
    assert repeats.taken(SCENE_TOPIC) == (2, 3, 4)
    assert repeats.taken("/tracks") == ()
