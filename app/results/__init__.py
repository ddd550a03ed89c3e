"""Writing a finished job: the bundle, the replay recording, provenance."""
