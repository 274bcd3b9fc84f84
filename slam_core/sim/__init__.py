"""The home simulator: the robot, its sensors and its home, so homebot runs without hardware.

- :mod:`.world` — world files (``load_world("flat")``, ``world_names()``), the :class:`World` geometry
- :mod:`.raycast` — exact numba ray casting against segments and circles
- :mod:`.robot` — :class:`SimRobot`: ``set_velocity(v, w)``, ``step(dt)``, ``ticks()``,
  ``true_pose``, ``odometry_pose`` (wheel slip, encoder quantisation, collisions)
- :mod:`.lidar` — 360-degree lidar; :mod:`.depth_camera` — Kinect-like depth images
- :mod:`.simulator` — :class:`Simulator` (world + robot + sensor + clock) and the scripted tour
- :mod:`.ground_truth` — the world rasterised as an occupancy grid
- :mod:`.record` — ``homebot sim record``: CARMEN log + ground-truth trajectory and map
"""
