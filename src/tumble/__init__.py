"""tumble: rigid-body dynamics after Baraff's SIGGRAPH 2001 notes, vectorised and compiled."""

__version__ = "0.1.0"
