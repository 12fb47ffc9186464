"""The aion model: pure numpy/scipy. No file I/O, no click, no rich."""
