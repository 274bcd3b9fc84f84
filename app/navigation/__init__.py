"""Goals to motion: planner (``slam_core.planning``) -> path follower -> velocity commands."""
