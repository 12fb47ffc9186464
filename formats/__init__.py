"""Everything that touches bytes: logs, messages, scene graphs, TF, tracks, map files, export."""
