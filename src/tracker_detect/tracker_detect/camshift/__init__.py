"""CamShift colour tracking of one target (seed 001)."""
