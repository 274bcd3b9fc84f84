"""Controllers that turn a path into velocity commands (the last step before the robot)."""
