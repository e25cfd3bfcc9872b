"""What a cluster run reports for a person: tables, the demo's plots, the harness's and the
lock-step benchmark's reports. Each reads a typed `RunRecord` or its JSON summary."""
