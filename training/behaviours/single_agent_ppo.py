"""Train one car among others with plain Stable-Baselines3 on a single-agent Gymnasium env.

    python training/behaviours/single_agent_ppo.py --env-id box2d_driving/Intersection-v0 \\
        --timesteps 200000 --out runs/single
    python training/behaviours/single_agent_ppo.py --quick --out runs/single_quick

No custom policy, no wrappers: ``PPO("MlpPolicy", gymnasium.make(ENV_ID))``. The other cars are
driven by the scenario's shipped policy (see ``box2d_driving/single_agent.py``). Writes
``OUT/policy.safetensors`` (the SB3 policy's weights, a format that cannot run code),
``OUT/config.json`` and ``OUT/progress.csv``, then prints the learner's success over a few
report episodes.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Optional

from training.common.cli_args import error, parse


@dataclass
class Args:
    """Train one car with SB3's PPO("MlpPolicy") on a single-agent Gymnasium env.

    env_id: a registered single-agent id (box2d_driving/Intersection-v0, Highway-v0, Crosswalk-v0, RealJunction-v0)
    timesteps: decisions of the learner's car to train for
    seed: seed of PPO and of the training episodes
    episodes: report episodes evaluated at the end
    quick: a real but short run (2,048 decisions, two PPO updates)
    out: output folder (must not exist or be empty)
    """

    env_id: str = "box2d_driving/Intersection-v0"
    timesteps: int = 200_000
    seed: int = 0
    episodes: int = 20
    quick: bool = False
    out: str = "runs/single_agent"


def main(argv: Optional[list[str]] = None) -> int:
    import gymnasium as gym
    import numpy as np
    from safetensors.torch import save_file
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import configure

    import box2d_driving  # noqa: F401  (registers the ids)
    from training.common.seeds import REPORT

    args = parse(Args, argv, description=__doc__.split("\n\n")[0])
    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        return error(f"{out} is not empty; choose another --out")
    if args.env_id not in gym.registry or not args.env_id.startswith("box2d_driving/"):
        ids = [k for k in gym.registry if k.startswith("box2d_driving/")]
        return error(f"unknown env id {args.env_id!r}; registered: {', '.join(ids)}")
    timesteps = min(args.timesteps, 2048) if args.quick else args.timesteps
    env = gym.make(args.env_id)
    model = PPO("MlpPolicy", env, seed=args.seed, n_steps=1024 if args.quick else 2048, verbose=0)
    out.mkdir(parents=True, exist_ok=True)
    model.set_logger(configure(str(out), ["csv"]))
    model.learn(timesteps)
    save_file({k: v.detach().cpu().contiguous() for k, v in model.policy.state_dict().items()},
              str(out / "policy.safetensors"))
    (out / "config.json").write_text(json.dumps({**asdict(args), "timesteps": timesteps}, indent=2))

    outcomes = []
    for seed in REPORT.episodes(args.episodes):
        obs, info = env.reset(seed=seed)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(int(action))
            done = terminated or truncated
        outcomes.append((bool(info["arrived"]), bool(info["collided"])))
    arrived, collided = np.mean(outcomes, axis=0)
    print(f"{args.env_id}, {timesteps} decisions: success {arrived:.3f}, collisions {collided:.3f} "
          f"over {args.episodes} report episodes; weights: {out / 'policy.safetensors'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
