"""Whole-body dynamics of legged gaits: dummy legs, inverse dynamics, force NLP/QP (paper 003)."""
