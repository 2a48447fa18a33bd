"""Worked examples from Goulet & Smith (2013)."""

from . import cantilever

__all__ = ["cantilever"]
