"""The ``box2d-driving`` command: ``list`` scenarios, ``bench`` the world."""

from __future__ import annotations

import argparse
import sys

import box2d_driving


def _list(_: argparse.Namespace) -> int:
    width = max(len(k) for k in box2d_driving.registry())
    for env_id, desc in box2d_driving.registry().items():
        print(f"{env_id:<{width}}  {desc}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="box2d-driving",
                                     description="Multi-agent Box2D driving worlds in which road rules emerge.")
    sub = parser.add_subparsers(dest="command", required=True)
    p_list = sub.add_parser("list", help="list the registered scenarios")
    p_list.set_defaults(func=_list)
    sub.add_parser("bench", help="world speed benchmark (agent-steps/s); see `bench --help`",
                   add_help=False)
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "bench":
        from box2d_driving import bench
        return bench.main(argv[1:])
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except box2d_driving.ConfigError as exc:
        print(f"box2d-driving: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
