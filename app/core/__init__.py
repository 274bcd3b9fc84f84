"""Settings and security shared by the server's parts."""
