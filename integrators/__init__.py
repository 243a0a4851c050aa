"""Time and load integrators for flexbody: static Newton, arc-length, Lie-group generalized-alpha."""
