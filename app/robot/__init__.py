"""The robot side: the simulated robot process (simulation mode) and the sensor sources a worker reads."""
