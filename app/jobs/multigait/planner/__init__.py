"""Motion planning for modular robots: maps, motion primitives, RRT and its cost terms (paper 001)."""
