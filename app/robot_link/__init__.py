"""The serial link to the robot's microcontroller: frame protocol and a virtual MCU on a pty."""
