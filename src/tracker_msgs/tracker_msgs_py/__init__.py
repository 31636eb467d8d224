"""Python helpers that go with tracker_msgs: the scene/pan-tilt geometry the messages document,
conversions between messages and plain Python values, and the parameter conventions shared by the
suite's nodes."""
