"""``python -m aion_cli`` runs the command line."""

from aion_cli.cli.main import main

main()
