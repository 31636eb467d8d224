"""The occupancy-grid particle filters (seed 002)."""
