"""Stability: the stiff sweep against theory and the extreme inputs, for `cavesim stability`."""
