"""hwgen: print files, checks and pictures for tendon-driven continuum robots."""
__version__ = "0.1.0"
