"""The version of polypack, in a module of its own (no import of the package needed to read it)."""

__version__ = "0.1.0"
