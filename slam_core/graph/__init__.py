"""The loop-closing back end: an SE(2) pose graph over a filter's trajectory, with
loop edges found by matching scans against submaps."""
