"""`deploy/gpu-check.sh`: what a CAVE operator runs on a new GPU node. Doctor, the test
suite, the bench, the shipped frame logs replayed bit for bit, the 4-wall demo; a summary
of at most 30 lines and gpu-check.json."""
