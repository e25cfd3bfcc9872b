"""The brownout demo's helicopter: rotor momentum theory, its downwash, saltation under
it, and the wand-driven flight that the master turns into each frame's parameters."""
