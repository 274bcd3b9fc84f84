"""Grabbers: threads that read one sensor each and publish its newest reading to shared state."""
