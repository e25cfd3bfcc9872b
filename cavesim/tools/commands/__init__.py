"""The subcommands of `cavesim`, one module per group; `cavesim.tools.cli` registers them."""
