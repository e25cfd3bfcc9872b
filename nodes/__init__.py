"""The cavesim processes (master, wall node): thin loops over the `cavesim` engine.

The cluster processes arrive with the lock-step cluster; until then the engine runs in
one process through `cavesim bench`.
"""
