"""`python -m cavesim ...` is the `cavesim` command (used to start child processes)."""

import sys

from nodes.cli import main

sys.exit(main())
