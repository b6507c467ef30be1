"""Record episodes of any env and any policy as a video (mp4 or GIF) and/or PNG frames."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Optional

if TYPE_CHECKING:  # for the annotations only: nothing of the policies is imported at run time
    from box2d_driving.policies.protocol import Policy


VIDEO_SUFFIXES = (".mp4", ".gif")


@dataclass
class Recording:
    """What was recorded: frame count, episodes, where, and seconds spent drawing per frame."""

    frames: int
    episodes: int
    video: Optional[Path]
    frames_dir: Optional[Path]
    render_seconds_per_frame: float


def mp4_available() -> bool:
    """Whether MP4 can be written here: imageio's ffmpeg plugin (the video or train extra)."""
    import importlib.util

    return importlib.util.find_spec("imageio_ffmpeg") is not None


def check_outputs(video: Optional[Path], frames_dir: Optional[Path], overwrite: bool) -> None:
    """Refuse to replace existing outputs unless ``overwrite``; reject unknown video formats."""
    if video is not None:
        if video.suffix.lower() not in VIDEO_SUFFIXES:
            raise ValueError(f"video file must end in {' or '.join(VIDEO_SUFFIXES)}: {video}")
        if video.suffix.lower() == ".mp4" and not mp4_available():
            from box2d_driving.plugins import install_hint

            raise ValueError(f"{video}: writing MP4 needs ffmpeg, which the video extra installs "
                             f"({install_hint('video')}); a .gif needs nothing more")
        if video.exists() and not overwrite:
            raise FileExistsError(f"{video} exists; pass --overwrite to replace it")
    if frames_dir is not None and frames_dir.exists() and any(frames_dir.iterdir()) and not overwrite:
        raise FileExistsError(f"{frames_dir} is not empty; pass --overwrite to write into it")


def record(env: Any, policy: Policy, episodes: int = 1, video: Optional[Path] = None,
           frames_dir: Optional[Path] = None, seed: Optional[int] = 0, fps: Optional[float] = None,
           overwrite: bool = False) -> Recording:
    """Run ``episodes`` episodes of ``env`` (``render_mode="rgb_array"``) with ``policy.act`` and
    write every decision's frame to ``video`` and/or ``frames_dir/frame_00000.png``..."""
    if env.render_mode != "rgb_array":
        raise ValueError("record() needs an env made with render_mode='rgb_array'")
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    video = Path(video) if video is not None else None
    frames_dir = Path(frames_dir) if frames_dir is not None else None
    check_outputs(video, frames_dir, overwrite)
    if frames_dir is None:
        return _record(env, policy, episodes, video, None, frames_dir, seed, fps)
    from box2d_driving.outputs import fresh_dir

    # frames go to a hidden sibling folder that replaces frames_dir whole at the end (no stale
    # frames of a longer earlier recording; nothing half-written after an interruption)
    with fresh_dir(frames_dir, overwrite) as tmp_frames:
        return _record(env, policy, episodes, video, tmp_frames, frames_dir, seed, fps)


def _record(env: Any, policy: Any, episodes: int, video: Optional[Path], frames_tmp: Optional[Path],
            frames_dir: Optional[Path], seed: Optional[int], fps: Optional[float]) -> Recording:
    import time

    import imageio.v2 as imageio

    from box2d_driving.outputs import terminate_as_interrupt

    fps = fps or env.config.render_fps
    writer = None
    if video is not None:
        video.parent.mkdir(parents=True, exist_ok=True)
        tmp = video.with_name(video.stem + ".partial" + video.suffix)
        if video.suffix.lower() == ".mp4":
            writer = imageio.get_writer(tmp, fps=fps, codec="libx264", quality=7,
                                        pixelformat="yuv420p", macro_block_size=16)
        else:
            writer = imageio.get_writer(tmp, mode="I", duration=1000.0 / fps, loop=0)
    count, drawing = 0, 0.0

    def emit() -> None:
        nonlocal count, drawing
        t0 = time.perf_counter()
        frame = env.render()
        drawing += time.perf_counter() - t0
        if writer is not None:
            writer.append_data(frame)
        if frames_tmp is not None:
            imageio.imwrite(frames_tmp / f"frame_{count:05d}.png", frame)
        count += 1

    try:
        with terminate_as_interrupt():  # SIGTERM, too, removes the partial video below
            for ep in range(episodes):
                obs, _ = env.reset(seed=None if seed is None else seed + ep)
                emit()
                while env.agents:
                    obs, *_ = env.step(policy.act({a: obs[a] for a in env.agents}))
                    emit()
    except BaseException:
        if writer is not None:
            writer.close()
            tmp.unlink(missing_ok=True)
        raise
    if writer is not None and video is not None:
        writer.close()
        os.replace(tmp, video)  # the finished video appears at once, never half-written
    return Recording(count, episodes, video, frames_dir, drawing / max(count, 1))
