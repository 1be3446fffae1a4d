"""omnislam.frontend."""
