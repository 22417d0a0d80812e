"""Checks read the exported files back; they never look at the builders' internals."""
