"""Checks read the exported files back and measure them; they never look at the builders' internals."""
