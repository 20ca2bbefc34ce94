"""Experiments built on the framework: benchmark reproductions and comparisons."""
