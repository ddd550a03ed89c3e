"""Leaf modules every layer may use: settings, asset paths, colours, plot helpers."""
