"""`python -m cavesim ...` is the `cavesim` command (used to start child processes)."""

import sys

from cavesim.tools.cli import main

sys.exit(main())
