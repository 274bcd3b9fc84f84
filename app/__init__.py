"""homebot's application layer: the command line, the server and its robot pipeline."""
