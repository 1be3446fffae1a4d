"""omnislam.fastslam."""
