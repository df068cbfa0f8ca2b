"""The painting station: pen tablets drive a physically-based watery-paint simulation."""

__version__ = "0.1.0"
