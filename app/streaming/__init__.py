"""Live streaming to browsers: the websocket hub and the binary map frame format (PROTOCOL.md)."""
