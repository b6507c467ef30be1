"""Pygame renderer: roads, lights, crosswalks, pedestrians, cars, goals, LiDAR, paths and a HUD.

``rgb_array`` draws onto an off-screen surface and never touches the display; ``human`` opens a
window. Where no display exists, ``SDL_VIDEODRIVER=dummy`` is set before pygame starts.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Optional

import numpy as np

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
import pygame

from box2d_driving.physics.world import ARRIVED, COLLIDED
from box2d_driving.road.geometry import rectangle_corners
from box2d_driving.road.layout import Layout
from box2d_driving.road.lights import GREEN, RED, YELLOW
from box2d_driving.render.scene import Scene

BACKGROUND = (34, 110, 52)
ROAD = (72, 72, 78)
EDGE = (235, 235, 235)
JUNCTION = (84, 84, 92)
STOP_LINE = (250, 250, 250)
CROSSWALK = (215, 215, 215)
PEDESTRIAN = (255, 140, 0)
COLLIDED_FILL = (150, 150, 150)  # grey body, dark outline, red cross: reads as grey, not red
COLLIDED_OUTLINE = (40, 40, 40)
COLLIDED_CROSS = (230, 30, 30)
RAY = (255, 255, 120)
RAY_DROPPED = (200, 60, 200)
HUD_TEXT = (255, 255, 255)
GREEN_RGB, YELLOW_RGB, RED_RGB = (30, 220, 60), (250, 200, 20), (235, 30, 30)
LIGHT_COLOURS = {GREEN: GREEN_RGB, YELLOW: YELLOW_RGB, RED: RED_RGB}


def light_colours(stop_value: float = RED) -> dict[float, tuple[int, int, int]]:
    """Colour of each light value when ``stop_value`` is the one drawn red: the other extreme is
    drawn green, yellow stays yellow (the scenario's own convention is ``stop_value=RED``)."""
    go = GREEN if stop_value == RED else RED
    return {stop_value: RED_RGB, go: GREEN_RGB, YELLOW: YELLOW_RGB}
CAR_PALETTE = [(31, 119, 180), (255, 127, 14), (148, 103, 189), (23, 190, 207), (227, 119, 194),
               (188, 189, 34), (140, 86, 75), (127, 127, 255), (255, 187, 120), (152, 223, 138),
               (197, 176, 213), (158, 218, 229), (247, 182, 210), (219, 219, 141), (196, 156, 148),
               (174, 199, 232)]


def car_colour(i: int) -> tuple[int, int, int]:
    """Fill colour of car ``i`` (live)."""
    return CAR_PALETTE[i % len(CAR_PALETTE)]


@dataclass(frozen=True)
class ViewerConfig:
    """Frame size (pixels), margin around the map (m), light disc radius (m), HUD font size, and
    for long roads (much longer than the frame's shape) the stretch of road shown (m): the view
    then fills the frame's height with the road and pans with the live cars."""

    width: int = 768
    height: int = 768
    margin: float = 4.0
    light_radius: float = 1.6
    font_size: Optional[int] = None  # None: 18 px on a 768 px wide frame, scaled with the width
    follow_span: float = 120.0


class Viewer:
    """Draws a :class:`~box2d_driving.render.scene.Scene` (``env.scene()``); keeps its surface (and
    window, in ``human`` mode)."""

    def __init__(self, mode: str, config: ViewerConfig = ViewerConfig(), show_lidar: bool = False,
                 fps: float = 4.0) -> None:
        if mode not in ("rgb_array", "human"):
            raise ValueError(f"render mode must be 'rgb_array' or 'human', got {mode!r}")
        self.mode = mode
        self.config = config
        self.show_lidar = show_lidar
        self.fps = fps
        pygame.font.init()
        size = config.font_size or max(11, min(18, round(18 * config.width / 768)))
        self.font = pygame.font.Font(None, size)
        self.surface = pygame.Surface((config.width, config.height))
        self.window: Optional[pygame.Surface] = None
        self.clock: Optional[pygame.time.Clock] = None
        self._view_for: Optional[Layout] = None

    # -- coordinates --------------------------------------------------------------------------
    def _fit(self, scene: Scene) -> None:
        """Scale and offset so the whole map fits the frame (world y up, pixels y down); a road
        much longer than the frame is wide is shown a stretch at a time (:meth:`_follow`)."""
        lay = scene.layout
        parts = [np.asarray(p) for p in lay.drivable] + [np.asarray(lay.edges).reshape(-1, 2)]
        pts = np.vstack([p for p in parts if len(p)])
        lo, hi = pts.min(axis=0) - self.config.margin, pts.max(axis=0) + self.config.margin
        w, h = self.config.width, self.config.height
        size = hi - lo
        self.bounds = (lo, hi)
        self.follow = size[0] > self.config.follow_span and size[0] / size[1] > 2.0 * w / h
        if self.follow:  # fixed zoom for the episode; the view pans
            self.scale = min(h / size[1], w / self.config.follow_span)
        else:
            self.scale = min(w / size[0], h / size[1])
        self._centre((lo + hi) / 2)
        self._view_for = lay

    def _centre(self, centre: np.ndarray) -> None:
        w, h = self.config.width, self.config.height
        self.offset = np.array([w / 2 - centre[0] * self.scale, h / 2 + centre[1] * self.scale])

    def _follow(self, scene: Scene) -> None:
        """Pan along a long road to the middle of the cars still driving (all cars once none is),
        never beyond the road's ends."""
        lo, hi = self.bounds
        live = scene.status == 0
        xs = scene.positions[live if live.any() else slice(None), 0]
        half = self.config.width / self.scale / 2
        x = float(np.clip((xs.min() + xs.max()) / 2, lo[0] + half, hi[0] - half))
        self._centre(np.array([x, (lo[1] + hi[1]) / 2]))

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        """World points ``(..., 2)`` (m) to pixel coordinates ``(..., 2)``."""
        p = np.asarray(points, dtype=float)
        return np.stack([self.offset[0] + p[..., 0] * self.scale,
                         self.offset[1] - p[..., 1] * self.scale], axis=-1)

    def _poly(self, colour, points, width: int = 0) -> None:
        pygame.draw.polygon(self.surface, colour, self.to_pixels(points).tolist(), width)

    # -- drawing ------------------------------------------------------------------------------
    def draw(self, scene: Scene) -> pygame.Surface:
        if self._view_for is not scene.layout:
            self._fit(scene)
        if self.follow:
            self._follow(scene)
        lay = scene.layout
        s = self.surface
        s.fill(BACKGROUND)
        for poly in lay.drivable:
            self._poly(ROAD, poly)
        if lay.junction_box is not None:
            x0, y0, x1, y1 = lay.junction_box
            self._poly(JUNCTION, np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
        if lay.junction_polygon is not None:
            self._poly(JUNCTION, lay.junction_polygon)
        if lay.crosswalk is not None:
            self._draw_crosswalk(lay.crosswalk)
        for poly in lay.crosswalks:
            self._poly(CROSSWALK, poly, 2)
        for a, b in np.asarray(lay.edges).reshape(-1, 2, 2):
            start, end = self.to_pixels(np.array([a, b])).tolist()
            pygame.draw.line(s, EDGE, start, end, 2)
        for a, b in np.asarray(lay.stop_lines).reshape(-1, 2, 2):
            start, end = self.to_pixels(np.array([a, b])).tolist()
            pygame.draw.line(s, STOP_LINE, start, end, 3)
        if scene.light_values is not None:
            palette = light_colours(scene.stop_value)
            for point, value in zip(self.light_positions(scene), scene.light_values):
                centre = self.to_pixels(point)
                radius = max(3, int(self.config.light_radius * self.scale))
                pygame.draw.circle(s, palette[float(value)], centre.tolist(), radius)
        for i, car in enumerate(lay.cars):  # paths and goals
            colour = car_colour(i)
            pygame.draw.lines(s, colour, False, self.to_pixels(car.path.points).tolist(), 1)
            gx, gy = self.to_pixels(car.path.points[-1])
            pygame.draw.circle(s, colour, (gx, gy), max(3, int(0.8 * self.scale)), 2)
        if self.show_lidar and scene.rays is not None and scene.dropped is not None:
            self._draw_lidar(scene, scene.rays, scene.dropped)
        for p, size in zip(scene.ped_positions, scene.ped_sizes):
            self._poly(PEDESTRIAN, rectangle_corners(p[0], p[1], 0.0, size, size))
        for i in range(len(scene.positions)):
            self._draw_car(i, scene.positions[i], scene.headings[i], scene.status[i], scene)
        self._draw_hud(scene)
        return s

    def light_positions(self, scene: Scene) -> np.ndarray:
        """Where each light is drawn: beyond the right end of its stop line (m)."""
        lights = scene.layout.lights
        if lights is None:
            return np.zeros((0, 2))
        right = np.stack([lights.directions[:, 1], -lights.directions[:, 0]], axis=1)
        lines = np.asarray(scene.layout.stop_lines).reshape(-1, 2, 2)
        if len(lines) == len(lights):
            ends = lines[:, 1]
        else:
            ends = lights.stop_points
        return ends + right * (self.config.light_radius + 0.5)

    def _draw_crosswalk(self, box) -> None:
        x0, y0, x1, y1 = box
        stripe = 1.0
        y = y0
        while y < y1:
            self._poly(CROSSWALK, np.array([[x0, y], [x1, y], [x1, min(y + stripe, y1)],
                                            [x0, min(y + stripe, y1)]]))
            y += 2 * stripe

    def _draw_car(self, i: int, pos, heading, status, scene: Scene) -> None:
        corners = rectangle_corners(pos[0], pos[1], heading, scene.car_length, scene.car_width)
        if status == ARRIVED:
            self._poly(car_colour(i), corners, 2)
            return
        if status == COLLIDED:
            self._poly(COLLIDED_FILL, corners)
            self._poly(COLLIDED_OUTLINE, corners, 1)
            px = self.to_pixels(corners)
            pygame.draw.line(self.surface, COLLIDED_CROSS, px[0].tolist(), px[2].tolist(), 2)
            pygame.draw.line(self.surface, COLLIDED_CROSS, px[1].tolist(), px[3].tolist(), 2)
            return
        self._poly(car_colour(i), corners)
        # heading: a bright wedge at the front
        front = np.array([pos[0], pos[1]]) + 0.5 * scene.car_length * np.array([math.cos(heading), math.sin(heading)])
        nose = self.to_pixels(front)
        centre = self.to_pixels(np.asarray(pos))
        pygame.draw.line(self.surface, (255, 255, 255), centre.tolist(), nose.tolist(), 2)

    def _draw_lidar(self, scene: Scene, all_rays: np.ndarray, all_dropped: np.ndarray) -> None:
        n_rays = all_rays.shape[1]
        angles = np.arange(n_rays) * (2 * math.pi / n_rays)
        for i in np.flatnonzero(scene.status == 0):
            rays, dropped = all_rays[i], all_dropped[i]
            origin = scene.positions[i]
            dist = np.where(np.isfinite(rays), rays, scene.lidar_range)
            th = scene.headings[i] + angles
            ends = origin + dist[:, None] * np.stack([np.cos(th), np.sin(th)], axis=1)
            o = self.to_pixels(origin).tolist()
            for k, end in enumerate(self.to_pixels(ends)):
                if dropped[k]:
                    colour = RAY_DROPPED
                elif np.isfinite(rays[k]):
                    colour = RAY
                else:
                    continue
                pygame.draw.line(self.surface, colour, o, end.tolist(), 1)

    def _draw_hud(self, scene: Scene) -> None:
        st = scene.status
        narrow = self.config.width < 500  # small frames (GIFs): the short forms
        text = (("" if narrow else f"{scene.name}  ") + f"decision {scene.decision}/{scene.horizon}  "
                f"arrived {int(np.sum(st == ARRIVED))}  collided {int(np.sum(st == COLLIDED))}  "
                f"driving {int(np.sum(st == 0))}")
        lines = [text]
        if scene.light_values is not None:  # which light value is drawn red, and why
            stop = scene.stop_value
            if stop == RED:
                lines.append(f"red light = value {stop:g} (the scenario's red)")
            elif narrow:
                lines.append(f"red light = value {stop:g}: this policy's stop")
            else:
                lines.append(f"red light = value {stop:g} (the value this policy stops on; "
                             f"the scenario calls it green)")
        y = 4
        for line in lines:
            label = self.font.render(line, True, HUD_TEXT)
            bg = pygame.Surface((label.get_width() + 8, label.get_height() + 6))
            bg.set_alpha(150)
            bg.fill((0, 0, 0))
            self.surface.blit(bg, (4, y))
            self.surface.blit(label, (8, y + 3))
            y += label.get_height() + 6

    # -- output -------------------------------------------------------------------------------
    def render(self, scene: Scene) -> Optional[np.ndarray]:
        surface = self.draw(scene)
        if self.mode == "rgb_array":
            return np.ascontiguousarray(np.transpose(pygame.surfarray.array3d(surface), (1, 0, 2)))
        if self.window is None:
            pygame.display.init()
            pygame.display.set_caption("box2d-driving")
            self.window = pygame.display.set_mode((self.config.width, self.config.height))
            self.clock = pygame.time.Clock()
        pygame.event.pump()
        self.window.blit(surface, (0, 0))
        pygame.display.flip()
        if self.clock is not None:
            self.clock.tick(self.fps)
        return None

    def close(self) -> None:
        if self.window is not None:
            pygame.display.quit()
            self.window = None
