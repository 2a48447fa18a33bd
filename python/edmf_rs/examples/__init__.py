"""Worked examples from Goulet & Smith (2013)."""

from ..paper import cantilever

__all__ = ["cantilever"]
