"""Stability margins (SSM, NESM, FASM), tipping judgment, adjustment leg and foothold, QP
foot-force distribution with friction and FASM cones (paper 002, Zhang et al. 2024)."""
