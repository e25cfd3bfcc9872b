"""Starting wall-node processes on this machine: the launcher, a whole local cluster (the
master in-process), and which GPU each wall computes on."""
