"""Rooms on the map: segmentation of the free space, and rooms that keep their ids as the map grows."""

from slam_core.rooms.segmentation import NO_ROOM, SegmentationConfig, segment_rooms

__all__ = ["NO_ROOM", "SegmentationConfig", "segment_rooms"]
