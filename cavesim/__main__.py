"""`python -m cavesim ...` is the `cavesim` command (used to start child processes)."""

import sys

from cavesim.cli import main

sys.exit(main())
