"""Pure numpy model math: shapes, lattice, and the reference rates."""

from .rates import rates

__all__ = ["rates"]
