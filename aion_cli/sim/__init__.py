"""aion_cli.sim package."""
