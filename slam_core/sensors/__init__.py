"""Sensor front ends: raw readings (encoder ticks, depth images) to odometry and scans."""
