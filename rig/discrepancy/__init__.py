"""Model discrepancy: what the linear model `u = H (y - B)` misses, named in the `effects.md` vocabulary."""

from rig.discrepancy.analysis import SCHEMA, analyze

__all__ = ["SCHEMA", "analyze"]
