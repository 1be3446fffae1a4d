"""Tolerances and sizes of the front-end tests, named in one place."""

#: two sightings in one track see true points closer than this [m] (the precision criterion)
SAME_POINT_M = 0.05
#: minimum track precision with geometric verification
MIN_TRACK_PRECISION = 0.99
#: minimum median number of verified bearings per processed image
MIN_SIGHTINGS_PER_IMAGE = 30
#: minimum median number of sightings of a track (the keypoint budget keeps ~45 % of the
#: demo's keypoints: median 5 on the full demo render, 6 without the budget; 4 on the test's
#: shorter render)
MIN_TRACK_LENGTH = 4
#: logged bearing sigmas agree with the RMS residuals against ground truth within this factor
MAX_NOISE_RATIO_ERROR = 1.5
#: median error of landmarks triangulated from the true poses (>= 3 deg of parallax) [m]
MAX_TRIANGULATION_MEDIAN_M = 0.02
#: images of the demo preset rendered for the tests (~0.2 m apart, half its loop)
DEMO_IMAGES = 24
#: images of corridor21 rendered for the vertical-edge tests
CORRIDOR_IMAGES = 12

#: a door-frame edge counts as detected within this of its true bearing [rad]
LINE_MATCH_RAD = 0.0175
#: fraction of the door-frame edges in view that must be detected
MIN_LINE_RECALL = 0.9
#: the pinhole corridor's recall counts door-frame lines up to this range [m]: farther, a 2.13 m
#: frame spans less than min_support (30 %) of the image height (480 px at f = 400 px)
PINHOLE_LINE_RANGE_M = 5.9
#: median bearing error of the detected edges [rad] (0.5 deg)
MAX_LINE_MEDIAN_RAD = 0.0087
#: median bearing error of the door-frame edges of the pinhole corridor [rad] (1 px at f = 400)
MAX_PINHOLE_LINE_MEDIAN_RAD = 0.0025
#: fraction of the door-frame lines whose MC passes Barra & Costa's photometric gate against the
#: surveyed MC of their landmark (67 % on corridor21: benchmarks/ukf_corridor21.py)
MIN_PHOTOMETRIC_PASS = 0.6
