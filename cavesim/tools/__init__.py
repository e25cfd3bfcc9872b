"""Offline tools on the library: the engine benchmark, numerics (error against run time),
stability, doctor, frame-log replay, and the reports of runs. Built on `cavesim.core` and
`cavesim.gpu`; the programs that drive processes are in `nodes`.

Each tool folder (`bench/`, `doctor/`, `numerics/`, `stability/`) names its parts by the same
roles: `report.py` writes its JSON and pictures, `display.py` shows it in the terminal.
"""
