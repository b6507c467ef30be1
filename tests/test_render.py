"""Headless rendering, videos, frame dumps and the CLI."""

import math

import numpy as np
import pytest

import box2d_driving
from box2d_driving.cli import main as cli
from box2d_driving.policies import LightRulePolicy, RandomPolicy
from box2d_driving.render.video import record
from box2d_driving.render.viewer import (COLLIDED_CROSS, COLLIDED_FILL, GREEN_RGB, LIGHT_COLOURS, RED_RGB,
                                         car_colour)
from box2d_driving.road.lights import GREEN, RED
from tests.helpers import hand_env, level_index, straight_car


def _pixel(frame, viewer, point):
    x, y = viewer.to_pixels(np.asarray(point, float))
    return tuple(frame[int(round(y)), int(round(x))])


def test_rgb_array_frame_shape_and_dtype():
    env = box2d_driving.make("intersection-v0", render_mode="rgb_array", render_size=(320, 240))
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8
    assert frame.std() > 0


@pytest.mark.parametrize("value", [RED, GREEN])
def test_light_is_drawn_in_its_colour(value):
    env = box2d_driving.make("intersection-v0", render_mode="rgb_array")
    for seed in range(100):
        env.reset(seed=seed)
        if env.layout.lights.values(0.0)[0] == value:
            break
    frame = env.render()
    viewer = env._viewer
    where = viewer.light_positions(env.scene())
    assert _pixel(frame, viewer, where[0]) == LIGHT_COLOURS[value]
    other = LIGHT_COLOURS[RED if value == GREEN else GREEN]
    assert _pixel(frame, viewer, where[1]) == other  # the other group, in antiphase


def test_car_is_drawn_where_its_body_is():
    env = box2d_driving.make("highway-v0", num_cars=3, render_mode="rgb_array")
    env.reset(seed=1)
    env.step({a: 20 for a in env.agents})
    frame = env.render()
    viewer = env._viewer
    for i in range(3):
        p, h = env.world.positions[i], env.world.headings[i]
        rear = p - 0.3 * env.config.car_length * np.array([math.cos(h), math.sin(h)]) \
            + 0.3 * env.config.car_width * np.array([-math.sin(h), math.cos(h)])
        assert _pixel(frame, viewer, rear) == car_colour(i)


def test_collided_cars_look_different():
    road = np.array([[-60, -8], [60, -8], [60, 8], [-60, 8]])
    env = hand_env([straight_car((-10, 0), (60, 0)), straight_car((10, 0), (-60, 0))],
                   render_mode="rgb_array", edges=[[[-60, -8], [60, -8]], [[-60, 8], [60, 8]]],
                   layout_kw={"drivable": [road]})
    env.reset(seed=0)
    up = level_index(env, 1.5)
    while env.agents:
        env.step({a: up for a in env.agents})
    frame = env.render()
    viewer = env._viewer
    p, h = env.world.positions[0], env.world.headings[0]
    # grey body (as the docs say) with a red cross through its centre
    side = p + 0.35 * env.config.car_width * np.array([-math.sin(h), math.cos(h)])
    assert _pixel(frame, viewer, side) == COLLIDED_FILL
    assert _pixel(frame, viewer, p) == COLLIDED_CROSS
    body = [np.array(_pixel(frame, viewer, p + np.array([dx, dy])))
            for dx in np.linspace(-2, 2, 9) for dy in np.linspace(-0.9, 0.9, 7)]
    reddish = sum(int(c[0]) > 200 and int(c[1]) < 80 for c in body)
    assert reddish < len(body) / 3  # mostly grey, not a red car


@pytest.mark.parametrize("stop_value", [RED, GREEN])
def test_the_light_value_a_policy_stops_on_is_drawn_red_and_said_in_the_legend(stop_value):
    env = box2d_driving.make("intersection-v0", render_mode="rgb_array", render_stop_value=stop_value)
    for seed in range(100):
        env.reset(seed=seed)
        if env.layout.lights.values(0.0)[0] == GREEN:
            break
    frame = env.render()
    where = env._viewer.light_positions(env.scene())
    expected = RED_RGB if stop_value == GREEN else GREEN_RGB
    assert _pixel(frame, env._viewer, where[0]) == expected
    plain = box2d_driving.make("intersection-v0", render_mode="rgb_array")
    plain.reset(seed=seed)
    legend = (slice(0, 60), slice(0, 500))  # the HUD's second line names the convention
    assert (frame[legend] != plain.render()[legend]).any() == (stop_value == GREEN)
    with pytest.raises(box2d_driving.ConfigError, match="render_stop_value"):
        box2d_driving.make("intersection-v0", render_stop_value=0.5)


def test_a_trained_policy_is_drawn_in_the_convention_it_adopted():
    from training import load_policy

    policy = load_policy("assets/policies/traffic_lights_4cars_noise05")
    assert policy.stop_value == 0.0  # its evaluation report: it stops on 0.0
    assert policy.make_env(render_mode="rgb_array").config.render_stop_value == 0.0
    assert policy.make_env().config.render_stop_value == 1.0  # not drawn: nothing changes
    assert load_policy("assets/policies/crosswalk_4cars_satnav").stop_value is None  # no lights


def test_render_without_mode_returns_none():
    env = box2d_driving.make("intersection-v0")
    env.reset(seed=0)
    with pytest.warns(UserWarning):
        assert env.render() is None


def test_human_mode_runs_headless():
    env = box2d_driving.make("crosswalk-v0", render_mode="human", render_fps=1000)
    env.reset(seed=0)
    assert env.render() is None
    env.close()


def test_mp4_decodes_to_the_expected_number_of_frames(tmp_path):
    import imageio.v2 as imageio

    env = box2d_driving.make("intersection-v0", render_mode="rgb_array", render_size=(256, 256))
    rec = record(env, LightRulePolicy(env), episodes=2, video=tmp_path / "v.mp4",
                 frames_dir=tmp_path / "frames", seed=3)
    reader = imageio.get_reader(tmp_path / "v.mp4")
    decoded = sum(1 for _ in reader)
    assert decoded == rec.frames
    assert len(list((tmp_path / "frames").glob("*.png"))) == rec.frames
    assert rec.frames > 2 * 2
    first = imageio.imread(tmp_path / "frames" / "frame_00000.png")
    assert first.shape == (256, 256, 3)
    with pytest.raises(FileExistsError):
        record(env, LightRulePolicy(env), video=tmp_path / "v.mp4")


def test_gif_output(tmp_path):
    env = box2d_driving.make("crosswalk-v0", render_mode="rgb_array", render_size=(128, 128),
                             horizon=4)
    rec = record(env, RandomPolicy(env, seed=0), video=tmp_path / "c.gif")
    assert (tmp_path / "c.gif").stat().st_size > 0 and rec.frames == 5


def test_cli_render_random_policy_writes_a_file(tmp_path, capsys):
    out = tmp_path / "run.mp4"
    code = cli(["render", "highway-v0", "--policy", "random", "--episodes", "1", "--out", str(out),
                "--set", "num_cars=3", "--set", "horizon=5", "--set", "render_size=(256, 256)",
                "--lidar"])
    assert code == 0 and out.stat().st_size > 0
    assert "wrote 6 frames" in capsys.readouterr().out


@pytest.mark.parametrize("argv,needle", [
    (["render", "nope-v0", "--out", "x.mp4"], "unknown env id"),
    (["render", "highway-v0", "--policy", "fancy", "--out", "{tmp}/x.mp4"], "unknown policy"),
    (["render", "highway-v0"], "nothing to write"),
    (["render", "highway-v0", "--out", "{tmp}/x.avi"], "must end in"),
    (["render", "highway-v0", "--out", "{tmp}/x.mp4", "--set", "num_cars=-2"], "num_cars"),
    (["render", "highway-v0", "--episodes", "many"], "invalid int"),
    (["frobnicate"], "invalid choice"),
])
def test_cli_bad_arguments_give_one_clear_line(tmp_path, capsys, argv, needle):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    try:
        code = cli(argv)
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert needle in err and len(err.splitlines()) == 1


def test_cli_list(capsys):
    assert cli(["list"]) == 0
    out = capsys.readouterr().out
    assert "intersection-v0" in out
    assert "scripted drivers: random, full-throttle, pedestrian-oracle; train: box2d-driving train crosswalk; " \
           "single-agent: box2d_driving/Crosswalk-v0" in out  # from the crosswalk's record


def test_long_roads_are_drawn_large_enough_to_see_and_the_view_follows_the_traffic():
    env = box2d_driving.make("highway-v0", render_mode="rgb_array")
    env.reset(seed=1)
    frame = env.render()
    viewer = env._viewer
    assert frame.shape[:2] == (400, 1280) and viewer.follow
    assert viewer.scale * env.config.car_length >= 40  # a car is at least 40 px long
    fast = env.action_space(env.agents[0]).n - 1
    for _ in range(12):
        if not env.agents:
            break
        env.step({a: fast for a in env.agents})
        frame = env.render()
        live = np.flatnonzero(env.world.status == 0)
        if len(live):
            xs = viewer.to_pixels(env.world.positions[live])[:, 0]
            assert 0 <= np.median(xs) < frame.shape[1]  # the view keeps up with the cars
    lo, hi = viewer.bounds
    assert viewer.to_pixels(np.array([hi[0], 0.0]))[0] >= frame.shape[1] - 1  # never beyond the road's end


def test_the_viewer_draws_a_public_scene_and_never_imports_the_envs():
    import ast
    from pathlib import Path

    import box2d_driving.render as render

    for path in Path(render.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        names = [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        names += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
        assert not [m for m in names if m.startswith("box2d_driving.envs")], path.name
        assert "._last_rays" not in path.read_text(), path.name  # no private env state
    env = box2d_driving.make("intersection-v0", render_mode="rgb_array", render_lidar=True)
    env.reset(seed=0)
    scene = env.scene()
    assert scene.rays.shape == (env.config.num_cars, env.config.n_rays) and scene.light_values is not None
    frame = env.render()
    from box2d_driving.render.viewer import Viewer, ViewerConfig

    again = Viewer("rgb_array", ViewerConfig(), show_lidar=True).render(scene)
    assert np.array_equal(frame, again)  # the scene is all the viewer needs


def test_mp4_without_ffmpeg_names_the_video_extra_and_a_gif_still_works(tmp_path, monkeypatch, capsys):
    from box2d_driving.render import video as video_module

    monkeypatch.setattr(video_module, "mp4_available", lambda: False)  # a base install: no imageio-ffmpeg
    env = box2d_driving.make("intersection-v0", num_cars=2, render_mode="rgb_array", horizon=3)
    with pytest.raises(ValueError, match=r"writing MP4 needs ffmpeg, which the video extra installs .*\[video\]"):
        record(env, RandomPolicy(env, seed=0), video=tmp_path / "v.mp4")
    assert not list(tmp_path.iterdir())  # nothing written
    assert cli(["render", "intersection-v0", "--out", str(tmp_path / "v.mp4"), "--set", "horizon=3"]) == 2
    assert "video extra" in capsys.readouterr().err
    rec = record(env, RandomPolicy(env, seed=0), video=tmp_path / "v.gif")
    assert rec.frames == 4 and (tmp_path / "v.gif").stat().st_size > 0
