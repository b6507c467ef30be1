"""``box2d-driving play``: drive one car yourself among the others, in a pygame window.

    box2d-driving play intersection-v0                       # the others: the shipped policy
    box2d-driving play real-junction-v0 --policy rule --set num_cars=6

Keys: hold Up to accelerate and Down to brake (the largest and smallest of the levels the
policies choose from), neither to hold your speed; 1-9 pick a level in between (1 = hardest
braking); R restarts, Esc or closing the window quits. Each decision is one second of the world;
``--fps`` decisions are played per real second (default 2). The other cars are driven as in the
single-agent Gymnasium envs (``box2d_driving/single_agent.py``): by the scenario's shipped
policy when it can be loaded, else by a scripted one, or by ``--policy``.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from box2d_driving.single_agent import SingleAgentDrivingEnv, single_agent_ids


def playable_ids() -> dict[str, tuple[Optional[str], str]]:
    """Env id -> (shipped background policy, scripted fall-back): the scenarios with a
    single-agent version, which ``play`` can seat you in."""
    return {env_id: (shipped, fallback) for env_id, shipped, fallback in single_agent_ids().values()}


def no_display_reason() -> Optional[str]:
    """Why a window could not be seen here (None where one can): SDL told to draw off-screen, or
    a Linux session with no X11 or Wayland display (a server, a container, an SSH shell)."""
    driver = os.environ.get("SDL_VIDEODRIVER", "")
    if driver in ("dummy", "offscreen"):
        return f"SDL_VIDEODRIVER={driver} draws into no window"
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "neither DISPLAY nor WAYLAND_DISPLAY is set"
    return None


@dataclass
class PlayResult:
    """What happened: one ``"arrived"``, ``"collided"`` or ``"time up"`` per finished episode."""

    outcomes: list[str]
    decisions: int
    quit: bool


class Keyboard:
    """The driver's action from the keys held down (tracked from pygame's key events, so that
    posted events drive it as real ones do)."""

    def __init__(self, levels: np.ndarray, n_actions: int) -> None:
        self.levels = np.asarray(levels, dtype=float)
        self.held: set[int] = set()
        self.picked: Optional[int] = None  # a level chosen with 1-9, until Up/Down
        self.n_actions = n_actions

    def handle(self, event: Any) -> Optional[str]:
        """Update from one event; returns "quit" or "restart" when asked."""
        import pygame

        if event.type == pygame.QUIT:
            return "quit"
        if event.type == pygame.KEYDOWN:
            if event.key == pygame.K_ESCAPE:
                return "quit"
            if event.key == pygame.K_r:
                return "restart"
            if pygame.K_1 <= event.key <= pygame.K_9:
                k = event.key - pygame.K_1  # 0..8 spread over the levels, 0 = hardest braking
                self.picked = int(round(k * (len(self.levels) - 1) / 8))
            self.held.add(event.key)
            if event.key in (pygame.K_UP, pygame.K_DOWN):
                self.picked = None
        elif event.type == pygame.KEYUP:
            self.held.discard(event.key)
        return None

    def action(self) -> int:
        import pygame

        if pygame.K_UP in self.held:
            return len(self.levels) - 1
        if pygame.K_DOWN in self.held:
            return 0
        if self.picked is not None:
            return self.picked
        return int(np.argmin(np.abs(self.levels)))  # hold the speed


def _status_lines(env: SingleAgentDrivingEnv, info: dict, outcome: Optional[str]) -> list[str]:
    par = env.parallel
    lines = [f"you (car 0): {info.get('speed', 0.0):.1f} m/s, {info.get('distance_to_goal', 0.0):.0f} m to go"]
    light = info.get("light")
    if par.layout is not None and par.layout.lights is not None and light is not None:
        stop = par.config.render_stop_value
        seen = {stop: "red", 1.0 - stop: "green", 0.5: "yellow"}.get(float(light), "none in view")
        lines.append(f"your light: {seen}")
    if outcome is not None:
        lines.append(f"{outcome}: R to drive again, Esc to quit")
    else:
        lines.append("Up: accelerate  Down: brake  1-9: a level  R: restart  Esc: quit")
    return lines


def play(env_id: str, policy: Optional[str] = None, fps: float = 2.0, episodes: Optional[int] = None,
         seed: Optional[int] = None, max_frames: Optional[int] = None, **overrides: Any) -> PlayResult:
    """Run the game until the window closes, Esc, or ``episodes`` episodes have ended
    (``max_frames`` bounds the frames drawn, for tests)."""
    playable = playable_ids()
    if env_id not in playable:
        raise ValueError(f"play knows {', '.join(playable)}; got {env_id!r}")
    if fps <= 0:
        raise ValueError(f"--fps must be > 0, got {fps}")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    shipped, fallback = playable[env_id]
    from box2d_driving.render.viewer import Viewer, ViewerConfig

    env = SingleAgentDrivingEnv(env_id, background=policy, fallback=fallback, shipped=shipped, **overrides)
    pygame.display.init()
    pygame.font.init()
    w, h = env.parallel.config.render_size
    window = pygame.display.set_mode((w, h))
    viewer = Viewer("rgb_array", ViewerConfig(width=w, height=h))  # draws into our window
    pygame.display.set_caption(f"box2d-driving play {env_id}")
    font = pygame.font.Font(None, 24)
    clock = pygame.time.Clock()
    keys = Keyboard(env.parallel.config.accelerations, env.parallel.config.n_actions)
    outcomes: list[str] = []
    decisions = frames = 0
    episode_seed = seed
    obs, info = env.reset(seed=episode_seed)
    outcome: Optional[str] = None
    quit_ = False
    try:
        while True:
            for event in pygame.event.get():
                asked = keys.handle(event)
                if asked == "quit":
                    quit_ = True
                elif asked == "restart":
                    episode_seed = None if episode_seed is None else episode_seed + 1
                    obs, info = env.reset(seed=episode_seed)
                    outcome = None
            if quit_:
                break
            if outcome is None:
                obs, _, terminated, truncated, info = env.step(keys.action())
                decisions += 1
                if terminated or truncated:
                    outcome = "arrived" if info["arrived"] else "collided" if info["collided"] else "time up"
                    outcomes.append(outcome)
            scene = env.parallel.scene()
            window.blit(viewer.draw(scene), (0, 0))
            you = viewer.to_pixels(scene.positions[0]).tolist()  # ring the player's car
            pygame.draw.circle(window, (255, 255, 255), you, max(12, int(3.0 * viewer.scale)), 2)
            window.blit(font.render("you", True, (255, 255, 255)), (you[0] + 14, you[1] - 24))
            y = h - 8
            for line in reversed(_status_lines(env, info, outcome)):
                label = font.render(line, True, (255, 255, 255))
                y -= label.get_height() + 6
                bg = pygame.Surface((label.get_width() + 10, label.get_height() + 6))
                bg.set_alpha(170)
                bg.fill((0, 0, 0))
                window.blit(bg, (6, y - 3))
                window.blit(label, (11, y))
            pygame.display.flip()
            frames += 1
            if (episodes is not None and len(outcomes) >= episodes) or \
                    (max_frames is not None and frames >= max_frames):
                break
            clock.tick(fps)
    finally:
        env.close()
        pygame.display.quit()
    return PlayResult(outcomes, decisions, quit_)
