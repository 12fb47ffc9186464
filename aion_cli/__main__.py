"""``python -m aion_cli`` runs the command line."""

from aion_cli.cli.entry import main

if __name__ == "__main__":  # not when a parallel build's worker process imports it
    main()
