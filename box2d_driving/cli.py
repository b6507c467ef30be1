"""The ``box2d-driving`` command.

Subcommands: ``list`` (scenarios), ``render`` (episodes to mp4/GIF/PNG frames), ``play`` (drive
a car yourself), ``bench`` (the
world speed benchmark), ``import-osm`` / ``import-nuscenes`` (a real junction from an
OpenStreetMap file or a nuScenes map-expansion JSON to a map JSON),
``train lights|crosswalk|lanes|fast-lanes|real-junction``, ``evaluate``, ``sweep``, ``reproduce``,
``curve``, ``check-shipped``, ``lidar-use`` and ``convert-checkpoint`` (the training scripts).
Bad arguments print one line and exit with status 2.
"""

from __future__ import annotations

import argparse
import ast
import os
import sys
from pathlib import Path
from typing import Any, Optional

import box2d_driving
from box2d_driving import plugins
from box2d_driving.cli_parser import OneLineParser


def _parse_overrides(pairs: list[str]) -> dict:
    out: dict[str, Any] = {}
    for pair in pairs:
        if "=" not in pair:
            raise ValueError(f"--set expects KEY=VALUE, got {pair!r}")
        key, value = pair.split("=", 1)
        if value.strip().lower() in ("true", "false"):  # --set remove_collided=false means False
            out[key] = value.strip().lower() == "true"
            continue
        try:
            out[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError, MemoryError, RecursionError):
            out[key] = value
    return out


def _list(_: argparse.Namespace) -> int:
    from box2d_driving.scenarios import scenarios

    records = scenarios()
    width = max(len(k) for k in records)
    for env_id, record in records.items():
        print(f"{env_id:<{width}}  {record.description}")
        more = [f"scripted drivers: {', '.join(record.baselines)}"]
        if record.trainer:
            more.append(f"train: box2d-driving train {record.trainer}")
        if record.single_agent:
            more.append(f"single-agent: {record.single_agent.gym_id}")
        print(f"{'':<{width}}  " + "; ".join(more))
    return 0


def _render(args: argparse.Namespace) -> int:
    from box2d_driving.policies import SCRIPTED, make_policy
    from box2d_driving.render.video import check_outputs, record

    overrides = _parse_overrides(args.set)
    overrides.update(render_mode="rgb_array", render_lidar=args.lidar)
    if args.fps is not None:
        overrides["render_fps"] = args.fps
    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    if args.out is None and args.frames is None:
        raise ValueError("nothing to write: give --out FILE.mp4 and/or --frames DIR")
    check_outputs(args.out, args.frames, args.overwrite)
    if args.policy in SCRIPTED:
        env = box2d_driving.make(args.env_id, **overrides)
        policy = make_policy(args.policy, env, seed=args.seed)
    elif Path(args.policy).exists():
        from box2d_driving.policies import load_trained

        policy = load_trained(args.policy)
        if policy.env_id != args.env_id:
            raise ValueError(f"{args.policy} was trained on {policy.env_id}, not {args.env_id}")
        env = policy.make_env(**overrides)
    else:
        raise ValueError(f"unknown policy {args.policy!r}: use {', '.join(SCRIPTED)} or a checkpoint path")
    rec = record(env, policy, episodes=args.episodes, video=args.out, frames_dir=args.frames,
                 seed=args.seed, overwrite=args.overwrite)
    where = " and ".join(str(p) for p in (rec.video, rec.frames_dir) if p is not None)
    print(f"wrote {rec.frames} frames of {rec.episodes} episode(s) to {where} "
          f"({rec.render_seconds_per_frame * 1000:.1f} ms per frame to draw)")
    return 0


def _play(args: argparse.Namespace) -> int:
    from box2d_driving.play import no_display_reason, play, playable_ids

    reason = no_display_reason()
    if reason is not None and args.env_id in playable_ids():  # else it would run on, unseen, until killed
        raise ValueError(f"play needs a window to show and no display is available ({reason}); to watch "
                         f"episodes without one, record them: box2d-driving render {args.env_id} --out episodes.mp4")

    result = play(args.env_id, policy=args.policy, fps=args.fps, seed=args.seed, **_parse_overrides(args.set))
    counts = {k: result.outcomes.count(k) for k in ("arrived", "collided", "time up")}
    print(f"{len(result.outcomes)} episode(s): " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    return 0


def _float_pair(text: str, flag: str, names: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"{flag} expects {names}, got {text!r}") from None
    return a, b


def _new_output(args: argparse.Namespace) -> Path:
    """The map importers' ``--out`` (and ``--png``), checked before anything is read: an existing
    file is replaced only with ``--overwrite``."""
    out = Path(args.out)
    for flag, path in (("--out", out), ("--png", args.png)):
        if path is not None and path.exists() and not args.overwrite:
            raise FileExistsError(f"{flag} {path} exists; pass --overwrite to replace it")
    if args.png is not None and Path(args.png).resolve() == out.resolve():
        raise ValueError("--png and --out name the same file")
    _check_writable("--out", out)
    _check_writable("--png", args.png)
    return out


def _import_osm(args: argparse.Namespace) -> int:
    from box2d_driving.maps import ImportConfig
    from box2d_driving.maps.osm import import_junction

    if (args.node is None) == (args.latlon is None):
        raise ValueError("give exactly one of --node ID or --latlon LAT,LON")
    where = args.node if args.latlon is None else _float_pair(args.latlon, "--latlon", "LAT,LON")
    out = _new_output(args)
    cfg = ImportConfig(size_m=args.size, drive_on=args.drive_on)
    _report_map(import_junction(args.file, where, cfg), out, args)
    return 0


def _import_nuscenes(args: argparse.Namespace) -> int:
    from box2d_driving.maps import ImportConfig
    from box2d_driving.maps.nuscenes import import_patch

    centre = args.segment if args.centre is None else _float_pair(args.centre, "--centre", "X,Y")
    out = _new_output(args)
    _report_map(import_patch(args.file, centre, ImportConfig(size_m=args.size)), out, args)
    return 0


def _report_map(roadmap, out: Path, args: argparse.Namespace) -> None:
    png = None
    if args.png is not None:  # drawn first: a picture that cannot be written leaves no map behind
        from box2d_driving.maps.plot import plot_map

        png = plot_map(roadmap, args.png)
    try:
        roadmap.save(out, overwrite=args.overwrite)
    except BaseException:
        if png is not None:
            png.unlink(missing_ok=True)
        raise
    arms = ", ".join(f"{a.name or a.id} ({len(a.lanes_in)} in/{len(a.lanes_out)} out)" for a in roadmap.arms)
    print(f"wrote {out}: {len(roadmap.arms)} arms [{arms}], {len(roadmap.connectors)} connectors, "
          f"{len(roadmap.signals)} signal heads, {len(roadmap.crosswalks)} crosswalks")
    for note in roadmap.notes:
        print(f"  note: {note}")
    if png is not None:
        print(f"wrote {png}")


def _map_output_arguments(p: argparse.ArgumentParser) -> None:
    """Options shared by the map importers: the cut-out size and where the map goes."""
    p.add_argument("--size", type=float, default=100.0, help="side of the square cut out (m, default 100)")
    p.add_argument("--out", required=True, help="map JSON to write")
    p.add_argument("--png", type=Path, help="also draw the map to this PNG (needs matplotlib)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out (and --png) file")


def build_parser() -> OneLineParser:
    """The parser of the world's own subcommands (the training ones are found by entry point)."""
    parser = OneLineParser(prog="box2d-driving",
                     description="Multi-agent Box2D driving worlds in which road rules emerge.")
    parser.add_argument("--version", action="version", version=f"box2d-driving {box2d_driving.__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    sub.add_parser("list", help="list the registered scenarios").set_defaults(func=_list)

    r = sub.add_parser("render", help="record episodes as a video and/or PNG frames")
    r.add_argument("env_id", help="a scenario id (see `box2d-driving list`)")
    r.add_argument("--policy", default="random",
                   help="random (default), rule (brake on 0.5/1.0 lights), full-throttle, constant-speed, "
                        "pedestrian-oracle, or a checkpoint (run folder or model.safetensors)")
    r.add_argument("--episodes", type=int, default=1, help="episodes to record (default 1)")
    r.add_argument("--out", type=Path, help="video file, .mp4 or .gif")
    r.add_argument("--frames", type=Path, help="also write PNG frames into this folder")
    r.add_argument("--lidar", action="store_true", help="draw LiDAR rays (dropped rays in magenta)")
    r.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    r.add_argument("--fps", type=float, help="video frames per second (default: the env's render_fps)")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="config override, e.g. --set num_cars=8 --set lidar_noise=0.25")
    r.add_argument("--overwrite", action="store_true", help="replace existing output files")
    r.set_defaults(func=_render)

    g = sub.add_parser("play", help="drive one car yourself among trained cars (a pygame window)")
    g.add_argument("env_id", help="intersection-v0, highway-v0, crosswalk-v0 or real-junction-v0")
    g.add_argument("--policy", help="who drives the other cars: a scripted policy (rule, random, "
                                    "full-throttle, constant-speed, pedestrian-oracle) or a checkpoint "
                                    "(default: the scenario's shipped policy in a source checkout, "
                                    "else a scripted one)")
    g.add_argument("--fps", type=float, default=2.0,
                   help="decisions (seconds of the world) per real second (default 2)")
    g.add_argument("--seed", type=int, help="seed of the first episode (default: a new one each time)")
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="config override, e.g. --set num_cars=6")
    g.set_defaults(func=_play)

    m = sub.add_parser("import-osm", help="import a real junction from an OpenStreetMap file (.osm.pbf/.osm)")
    m.add_argument("file", help="OSM extract (.osm.pbf or .osm XML)")
    m.add_argument("--node", type=int, help="OSM node id of the junction")
    m.add_argument("--latlon", help="or the junction nearest to LAT,LON")
    m.add_argument("--drive-on", choices=("right", "left"), default="right",
                   help="the side traffic keeps to (default right; left: UK, Japan, Singapore, ...)")
    _map_output_arguments(m)
    m.set_defaults(func=_import_osm)

    n = sub.add_parser("import-nuscenes", help="import a junction from a nuScenes map-expansion JSON")
    n.add_argument("file", help="map-expansion JSON (e.g. boston-seaport.json)")
    n.add_argument("--centre", help="X,Y (map metres) inside or near the intersection")
    n.add_argument("--segment", help="or the intersection's road_segment token")
    _map_output_arguments(n)
    n.set_defaults(func=_import_nuscenes)

    sub.add_parser("bench", help="world speed benchmark (agent-steps/s); `bench --help` for options",
                   add_help=False)
    sub.add_parser("train", help="train: `train lights|crosswalk|lanes|fast-lanes|real-junction [options]` "
                                 "(`train lights --help`)",
                   add_help=False)
    sub.add_parser("evaluate", help="evaluate a checkpoint or scripted policy (`evaluate --help`)",
                   add_help=False)
    sub.add_parser("sweep", add_help=False,
                   help="a grid of settings x seeds on Ray Tune, evaluated on report seeds (`sweep --help`)")
    sub.add_parser("reproduce", add_help=False,
                   help="write docs/results.md and its figures from sweep summaries (`reproduce --help`)")
    sub.add_parser("curve", add_help=False,
                   help="learning curves of a run's or a sweep's checkpoints on selection seeds (`curve --help`)")
    sub.add_parser("check-shipped", add_help=False,
                   help="every shipped policy's reported rates against a fresh block of report episodes "
                        "(`check-shipped --help`)")
    sub.add_parser("convert-checkpoint", add_help=False,
                   help="convert an older pickled model.zip of your own to model.safetensors "
                        "(`convert-checkpoint --help`)")
    sub.add_parser("original", add_help=False,
                   help="the paper's own simulator and trainer (sdriving 0.1.0) beside ours (`original --help`)")
    sub.add_parser("lidar-use", add_help=False,
                   help="whether trained actors use their LiDAR (a dead encoder is blind; `lidar-use --help`)")
    parser.commands = sub.choices  # name -> sub-command parser
    return parser


# the sub-commands the training package provides (box2d_driving/plugins.py)
DELEGATED = ("train", "evaluate", "convert-checkpoint", "sweep", "reproduce", "curve", "check-shipped", "original",
             "lidar-use")


def _delegate(argv: list[str]) -> int:
    """``train``, ``evaluate``, ``sweep``, ... run the training package's scripts (they need the
    train extra)."""
    if argv[0] != "train":
        name, rest = argv[0], argv[1:]
    else:
        trainers = plugins.behaviours()
        if len(argv) >= 2 and argv[1] in ("-h", "--help"):
            print(f"usage: box2d-driving train {{{','.join(trainers)}}} [options]\n\n"
                  f"Train a behaviour; `box2d-driving train BEHAVIOUR --help` lists its options.")
            return 0
        if len(argv) < 2 or argv[1] not in trainers:
            print(f"box2d-driving: error: train needs a behaviour: {', '.join(trainers) or 'none installed'} "
                  f"(got {argv[1] if len(argv) > 1 else 'none'!r})", file=sys.stderr)
            return 2
        name, rest = f"train:{argv[1]}", argv[2:]
    try:
        script = plugins.require(name)
    except plugins.CommandMissing as exc:
        print(f"box2d-driving: error: {argv[0]} {exc}", file=sys.stderr)
        return 2
    # usage lines and error prefixes name the command the user typed, not the script's file
    saved, sys.argv[0] = sys.argv[0], "box2d-driving " + " ".join(argv[:1] if argv[0] != "train" else argv[:2])
    try:
        return script(rest)
    except OSError as exc:
        return _file_error(sys.argv[0], exc)
    finally:
        sys.argv[0] = saved


def _file_error(prog: str, exc: OSError) -> int:
    """A file or folder the command could not read or write (``--out`` a file where a folder
    goes, a folder that cannot be created, a full disk): one line naming it, exit status 2.
    Errors that name no file are not the user's input: they propagate."""
    if exc.filename is None:
        raise exc
    name = str(exc.filename)
    for scratch in (".partial", ".tmp"):  # the file written beside the one asked for, then renamed
        name = name[: -len(scratch)] if name.endswith(scratch) else name
    print(f"{prog}: error: {name}: {exc.strerror or exc}", file=sys.stderr)
    return 2


def _check_writable(flag: str, path: Optional[Path]) -> None:
    """``path`` can be created: its folder exists (or can be made) and is writable; checked
    before any work, so that nothing is left half done."""
    if path is None:
        return
    folder = Path(path).resolve().parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise ValueError(f"{flag} {path}: cannot write there ({folder} is not a writable folder)")


def main(argv: list[str] | None = None) -> int:
    """Run ``box2d-driving`` with ``argv`` (default the process's arguments); returns the exit status."""
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "bench":
        from box2d_driving import bench
        return bench.main(argv[1:])
    if argv and argv[0] in DELEGATED:
        return _delegate(argv)
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # reported by the sub-command's parser, so the line names the command
        parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        return args.func(args)
    except (ValueError, FileExistsError) as exc:  # ConfigError is a ValueError
        print(f"box2d-driving {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        return _file_error(f"box2d-driving {args.command}", exc)


if __name__ == "__main__":
    raise SystemExit(main())
