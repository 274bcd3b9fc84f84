"""The estimator process: grabbers -> synchronised steps -> published pose, particles, scan and map."""
