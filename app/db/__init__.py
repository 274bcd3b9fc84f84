"""Persistent storage: named places and saved maps in SQLite, map files beside the database."""
