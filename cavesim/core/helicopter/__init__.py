"""The brownout demo's helicopter: rotor momentum theory, its downwash, saltation under
it, the wand-driven flight the helicopter scene driver advances on the master, and what a
frame's rotor gives the engine and the twin (`inputs`)."""
