"""homebot's numeric core: geometry, occupancy grids, SLAM, localization and planning (numpy + numba)."""
