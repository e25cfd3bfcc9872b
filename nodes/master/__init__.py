"""The master process: the clock, the randomness, the barrier and the vote (`process.py`),
its link to the walls over Zenoh, the forensics and tolerance it applies, and what it
records of a run."""
