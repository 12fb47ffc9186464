"""The temporal model: rates per entry and direction bin, several forecast families, chosen
per entry by day-ahead score (see the modules' docstrings; DESIGN.md §4)."""
