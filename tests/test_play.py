"""``box2d-driving play``, headless: key events posted into pygame's queue drive the car."""

from __future__ import annotations

import sys

import os

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
pygame = pytest.importorskip("pygame")

from box2d_driving.play import Keyboard, play  # noqa: E402


def _post(*keys, up=False):
    pygame.display.init()
    for key in keys:
        pygame.event.post(pygame.event.Event(pygame.KEYUP if up else pygame.KEYDOWN, key=key))


def test_holding_up_drives_a_whole_episode_at_full_throttle():
    pygame.display.init()
    pygame.event.clear()
    _post(pygame.K_UP)
    result = play("intersection-v0", policy="rule", fps=1000, episodes=1, seed=4, num_cars=3)
    assert len(result.outcomes) == 1 and result.outcomes[0] in ("arrived", "collided", "time up")
    assert not result.quit and result.decisions >= 1


def test_escape_quits_and_restart_starts_a_new_episode():
    pygame.display.init()
    pygame.event.clear()
    _post(pygame.K_r, pygame.K_ESCAPE)
    result = play("highway-v0", fps=1000, seed=0, max_frames=50, num_cars=3)
    assert result.quit and result.decisions == 0


def test_keys_map_to_the_policies_acceleration_levels():
    levels = [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5]
    keys = Keyboard(levels, len(levels))
    assert keys.action() == 3  # nothing held: zero acceleration
    pygame.display.init()
    for key, expected in ((pygame.K_UP, 6), (pygame.K_DOWN, 0)):
        keys.handle(pygame.event.Event(pygame.KEYDOWN, key=key))
        assert keys.action() == expected
        keys.handle(pygame.event.Event(pygame.KEYUP, key=key))
    keys.handle(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_1))
    assert keys.action() == 0
    keys.handle(pygame.event.Event(pygame.KEYDOWN, key=pygame.K_9))
    assert keys.action() == 6
    assert keys.handle(pygame.event.Event(pygame.QUIT)) == "quit"


def test_play_refuses_what_it_cannot_play(capsys):
    from box2d_driving.cli import main as cli

    assert cli(["play", "intersection-spline-v0"]) == 2
    assert "play knows" in capsys.readouterr().err
    with pytest.raises(ValueError, match="fps"):
        play("intersection-v0", fps=0)


def test_play_without_a_display_says_so_and_points_at_render(capsys, monkeypatch):
    from box2d_driving.cli import main as cli

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")  # as on a server: nothing would be seen
    assert cli(["play", "intersection-v0"]) == 2
    err = capsys.readouterr().err
    assert "no display is available (SDL_VIDEODRIVER=dummy" in err and "box2d-driving render intersection-v0" in err
    monkeypatch.delenv("SDL_VIDEODRIVER")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if sys.platform.startswith("linux"):
        assert cli(["play", "highway-v0"]) == 2 and "DISPLAY nor WAYLAND_DISPLAY" in capsys.readouterr().err
