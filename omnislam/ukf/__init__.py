"""omnislam.ukf."""
