"""The wall-node process (`process.py`): one GL context stepped in lock-step, what reaches it
(inbox), how it resyncs (snapshots, delta), what it shows (screen, preview controls; its
pictures are `cavesim.gpu.render.painter`'s) and the drift sample it reports in the
mixed-hardware mode."""
