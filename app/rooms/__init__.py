"""Rooms on the live map: segmented in the background, kept stable, edited by people, stored per map."""
