"""What a frame shows: a snapshot of an env that the viewer draws without knowing the env.

``DrivingEnv.scene()`` builds one; :class:`~box2d_driving.render.viewer.Viewer` draws it. The
viewer therefore imports nothing from ``box2d_driving.envs`` (the env imports the viewer, not the
reverse), and reads no private state: what it draws is exactly this.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from box2d_driving.road.layout import Layout


@dataclass(frozen=True)
class Scene:
    """One moment of one episode, in world units.

    Attributes:
        name: scenario name (HUD).
        decision, horizon: decisions done and the episode's horizon.
        layout: the episode's map, spawns, paths and lights.
        light_values: each light's value now (``None`` without lights).
        positions: car centres ``(N, 2)`` (m); headings ``(N,)`` (rad); status ``(N,)`` (0 driving,
            then ``ARRIVED`` / ``COLLIDED`` of :mod:`box2d_driving.physics.world`).
        car_length, car_width: car body size (m).
        ped_positions: pedestrian centres ``(P, 2)`` (m); ped_sizes ``(P,)`` (m, square side).
        stop_value: the light value drawn red (``render_stop_value``).
        rays: each car's LiDAR hit distances ``(N, n_rays)`` (m, ``inf`` = no hit) at its last
            decision, ``None`` unless rays are drawn; dropped: the rays noise dropped, same shape.
        lidar_range: LiDAR range (m), the length of a ray that hit nothing.
    """

    name: str
    decision: int
    horizon: int
    layout: Layout
    light_values: Optional[np.ndarray]
    positions: np.ndarray
    headings: np.ndarray
    status: np.ndarray
    car_length: float
    car_width: float
    ped_positions: np.ndarray
    ped_sizes: np.ndarray
    stop_value: float = 1.0
    rays: Optional[np.ndarray] = None
    dropped: Optional[np.ndarray] = None
    lidar_range: float = 50.0
