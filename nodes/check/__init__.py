"""The consistency harness (`cavesim check`): it runs a cluster, injects faults and attacks
(its rogue peer), and says what became of each."""
