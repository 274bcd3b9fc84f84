"""Replay: a CARMEN log played through the live path as if a robot were sending it."""
