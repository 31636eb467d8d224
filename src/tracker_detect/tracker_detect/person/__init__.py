"""The learned person model and its fusion with motion (person, person_motion)."""
