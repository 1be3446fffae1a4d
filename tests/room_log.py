"""A tiny corrected CARMEN log written into a test folder (harness, report and cli tests).

The log is a robot driving a loop in a 10 m x 8 m room; its FLASER poses are the (pseudo)
ground truth, the ODOM chain between them carries seeded odometry noise, and the 36-beam scans
are ray-cast against the walls and four poles near the corners: the poles are the front end's
laser landmarks (spikes), since 36 beams give no corner (two walls of at least 30 readings
each). The registry reads it like the real CARMEN logs, so the runner,
the metrics and the report are exercised without the real data.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from omnislam.core.se import se2_compose

#: the room: x in [0, ROOM_X], y in [0, ROOM_Y] [m]
ROOM_X, ROOM_Y = 10.0, 8.0
BEAMS = 36
MAX_RANGE_M = 30.0
#: poles (x, y) [m] of radius POLE_RADIUS_M, 1.5 m from two walls each
POLES = ((1.5, 1.5), (8.5, 1.5), (8.5, 6.5), (1.5, 6.5))
POLE_RADIUS_M = 0.15


def ray_cast_room(
    x: float, y: float, angles: np.ndarray, poles=POLES, pole_radius_m: float = POLE_RADIUS_M
) -> np.ndarray:
    """(B,) exact ranges [m] from (x, y) along the world angles ``angles`` to the nearest of the
    room's walls and the poles ``poles`` ((x, y) centres [m] of radius ``pole_radius_m``)."""
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 0, (ROOM_X - x) / c, np.where(c < 0, -x / c, np.inf))
        ty = np.where(s > 0, (ROOM_Y - y) / s, np.where(s < 0, -y / s, np.inf))
    ranges = np.minimum(tx, ty)
    for px, py in poles:  # ray-circle intersections
        b = c * (px - x) + s * (py - y)
        disc = b**2 - ((px - x) ** 2 + (py - y) ** 2 - pole_radius_m**2)
        hit = (disc >= 0) & (b > 0)
        ranges = np.where(hit, np.minimum(ranges, b - np.sqrt(np.maximum(disc, 0.0))), ranges)
    return ranges


def write_room_log(path: Path, frames: int = 60, seed: int = 0, beams: int = BEAMS) -> Path:
    """Write a corrected CARMEN log of a loop in the room (see the module docstring), with
    ``beams`` beams per scan."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2.0 * np.pi, frames, endpoint=False)
    truth = np.column_stack(
        [5.0 + 3.0 * np.cos(t), 4.0 + 2.5 * np.sin(t), t + np.pi / 2.0]
    )  # an ellipse, heading along it
    beam_angles = -np.pi / 2 + np.arange(beams) * np.pi / beams
    lines = []
    for k, pose in enumerate(truth):
        stamp = 1.0 + k
        if k:
            c, s = np.cos(truth[k - 1, 2]), np.sin(truth[k - 1, 2])
            d = truth[k, :2] - truth[k - 1, :2]
            delta = np.array(
                [c * d[0] + s * d[1], -s * d[0] + c * d[1], truth[k, 2] - truth[k - 1, 2]]
            )
            noisy = delta + rng.normal(0.0, [0.02, 0.01, 0.01])
            raw = se2_compose(truth[k - 1], noisy)
            lines.append(f"ODOM {raw[0]:.6f} {raw[1]:.6f} {raw[2]:.6f} 0 0 0 {stamp:.3f} h {stamp}")
        ranges = ray_cast_room(pose[0], pose[1], pose[2] + beam_angles)
        ranges = np.minimum(ranges + rng.normal(0.0, 0.01, beams), MAX_RANGE_M)
        r = " ".join(f"{v:.3f}" for v in ranges)
        p = f"{pose[0]:.6f} {pose[1]:.6f} {pose[2]:.6f}"
        lines.append(f"FLASER {beams} {r} {p} {p} {stamp:.3f} h {stamp}")
        lines.append(f"ODOM {p} 0 0 0 0 h 0")  # reset to the corrected pose (corrected log)
    path.write_text("\n".join(lines) + "\n")
    return path
