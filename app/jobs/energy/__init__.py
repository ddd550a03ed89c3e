"""Job kind ``energy``: energy-optimal quadruped gaits with heavy legs (paper 003)."""
