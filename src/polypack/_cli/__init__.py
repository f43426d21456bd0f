"""CLI command modules; each defines ``register(app)`` (see :mod:`polypack.cli`)."""
