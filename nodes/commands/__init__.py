"""The subcommands of `cavesim`, one module each, named after the subcommand: its flags in,
a typed call out."""
