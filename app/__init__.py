"""gaitmend: gait recovery for damaged legged robots."""

__version__ = "0.1.0"
