"""Benchmarks that run whole clusters of processes: the barrier's cost (`cavesim bench
--cluster`), the swap skew, the soak and the resync."""
