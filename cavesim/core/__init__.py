"""The core: everything cavesim knows without a GL context.

Scenes and CAVE files, the frame's inputs and the particle records, the scene drivers,
the master's clock, the wire between the processes, a tracking system's datagrams
mapped to head and wand, the frame log and the float64 twin.
The master imports nothing above this layer.
"""
