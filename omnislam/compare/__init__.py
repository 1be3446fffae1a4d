"""omnislam.compare."""
