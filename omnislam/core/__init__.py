"""Pure numpy/scipy mathematics shared by every estimator, the simulator and the front end.

Nothing here imports matplotlib, OpenCV, YAML, file formats or the CLI (a test enforces it).
"""
