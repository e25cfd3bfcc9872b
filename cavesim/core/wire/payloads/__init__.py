"""The payload layouts of the wire's messages, one module per sender: `from_master`
(frames, commands, info requests), `from_nodes` (reports, GPU info, swap steps),
`state_transfer` (snapshots and blocks of a node's state) and `poses` (head and wand, and
the tracker's message). The header and signatures around them are `../envelope.py`."""
