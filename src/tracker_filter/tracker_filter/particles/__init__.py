"""The colour particle filters (seed 003): one particle filter per target."""
