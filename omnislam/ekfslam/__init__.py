"""omnislam.ekfslam."""
