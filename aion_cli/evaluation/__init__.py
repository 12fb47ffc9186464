"""aion_cli.evaluation package."""
