"""Alpha-beta and Kalman tracking with multi-target track management and target selection."""
