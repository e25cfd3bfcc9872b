"""`cavesim doctor`: what a CAVE administrator runs first on a new node.

It lists the EGL devices and examines each in a child process (`probe`), opens the zenoh
session the node would open and asks whether windows can open (`checks`), judges whether
the node can run cavesim (`verdict`), and prints and writes it all (`report`).
"""
