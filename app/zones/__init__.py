"""No-go zones and virtual walls of the map in use, for the planner, the API and MQTT."""
