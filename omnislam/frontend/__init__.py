"""The shared front end: one omnidirectional-camera (and laser) front end for every estimator.

A Sequence goes in, an ObservationLog comes out (``pipeline.run_frontend``), cached on disk
(``observation_log``) and replayed to every back end, so a comparison measures estimators and
not front ends. Modules, one concept each:

- ``config``: frozen configuration records, SIFT presets ``LOWE`` and ``OMNI_THESIS``, hash;
- ``sift``: SIFT on the raw omni image inside the usable ring (OpenCV or pycolmap);
- ``groups``: feature groups, the thesis's "objects" (4.1.3);
- ``matching``: ratio test, brute force frame to frame, FLANN kd-tree against the map,
  object-level validation (4.2);
- ``verification``: RANSAC essential matrix on bearing vectors, seeded by odometry;
- ``tracks``: stable landmark ids, re-recognition against the map, pruning (4.2);
- ``observation_log``: the versioned, compressed, keyed log file;
- ``pipeline``: Sequence -> ObservationLog, asynchronous image schedule;
- ``image_tracking``: the per-image stages (groups, rays, sigmas, landmark and floor tracks);
- ``vertical_edges``: vertical lines with PMC/MC colour profiles (Barra & Costa);
- ``laser_landmarks``: spikes and RANSAC lines (SLAM for Dummies);
- ``evaluation``: quality against the renderer's per-pixel ground truth.
"""
