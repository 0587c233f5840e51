"""agnav configs and the graph runner (the agnav CLI)."""
