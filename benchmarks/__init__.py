"""Comparisons of cavesim with other tools, each run as a script: python benchmarks/NAME.py."""
