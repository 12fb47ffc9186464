"""aion: 4D scene graphs (3D scene graphs with temporal flow dynamics) from robot logs."""

__version__ = "0.1.0"
