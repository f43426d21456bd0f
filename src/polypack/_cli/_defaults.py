"""CLI defaults from the Python API: one place for every default (the function's signature)."""

from __future__ import annotations

import inspect


def api_default(func, name: str):
    """Default of keyword ``name`` of ``func`` (the generators' signatures hold the defaults)."""
    return inspect.signature(func).parameters[name].default
