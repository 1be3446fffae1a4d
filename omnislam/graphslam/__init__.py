"""omnislam.graphslam."""
