"""The paper's own training commands, as typed settings.

The original experiment list (``EXPERIMENTS.md`` of the paper's code, sdriving 0.1.0) trains the
traffic-light claims with ``sdriving.agents.ppo_distributed.train`` on
``MultiAgentRoadIntersectionFixedTrackDiscreteEnvironment``. Every 4-car noise run there reads

``-se 32000 -e 75 --pi-lr 1e-3 --vf-lr 1e-3 --entropy-coeff 0.0001 --target-kl 0.2 -ti 20``
``--ac-kwargs {"hidden_sizes": [256, 256], "history_len": 5, "permutation_invariant": true}``
``--env-kwargs {"horizon": 250, "nagents": 4, "lidar_noise": NOISE, "history_len": 5,``
``"timesteps": 10, "npoints": 100, "turns": false, "learn_right_of_way": false,``
``"default_color": true, "balance_cars": true}``

with 50 epochs for noise 1.0 and a seed of its own per run (17927, 11407, 31085, 15657). Units:
an epoch is ``steps_per_epoch`` *joint* env steps (every live car of the instance decides at each
one); ``horizon`` counts physics steps of 0.1 s, ``timesteps`` of them per decision, so 250 / 10
is 25 decisions.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

ENV = "MultiAgentRoadIntersectionFixedTrackDiscreteEnvironment"
# epochs of the original command per LiDAR noise level (EXPERIMENTS.md, "Analyzing the Effect of
# Increased Perception Noise")
NOISE_EPOCHS = {0.25: 75, 0.5: 75, 0.75: 75, 1.0: 50}
# the original's 1-car run on its turning junction ("Single Agent Traffic Light Experiment"):
# 60 epochs at entropy 1e-3, LiDAR noise 0, one car
LONE_CAR_EPOCHS = 60
LONE_CAR_ENTROPY = 1e-3
# the seed each of those original commands passes; ours use training seeds 0, 1, ... instead
ORIGINAL_SEEDS = {0.25: 17927, 0.5: 11407, 0.75: 31085, 1.0: 15657}


class OriginalError(ValueError):
    """A setting of an original-code run, or its folder, is invalid."""


@dataclass(frozen=True)
class TrainerSettings:
    """``ppo_distributed.train``'s options as the original commands set them.

    Attributes:
        steps_per_epoch: joint env steps per epoch (``-se``).
        train_iters: minibatches in the epoch's one pass (``-ti``).
        pi_lr: actor learning rate (Adam).
        vf_lr: critic learning rate (a separate Adam).
        entropy_coeff: entropy bonus.
        target_kl: the actor's step is skipped for the rest of the pass once the approximate KL
            exceeds 1.5 x this (the critic keeps training).
        gamma: discount.
        lam: GAE lambda.
        clip_ratio: PPO clip, also the value clip.
    """

    steps_per_epoch: int = 32_000
    train_iters: int = 20
    pi_lr: float = 1e-3
    vf_lr: float = 1e-3
    entropy_coeff: float = 1e-4
    target_kl: float = 0.2
    gamma: float = 0.99
    lam: float = 0.97
    clip_ratio: float = 0.2


@dataclass(frozen=True)
class OriginalRun:
    """One run of the original trainer on the original world.

    Attributes:
        lidar_noise: share of LiDAR rays dropped (each ray independently, in the original).
        seed: training seed (the run seeds torch, numpy and Python's ``random`` with it).
        epochs: epochs of ``trainer.steps_per_epoch`` joint steps; None: the original command's
            (with ``turns``, its 1-car run's 60).
        nagents: cars per instance.
        balance_cars: approaches in round robin from a random first one (True) or each drawn
            at random (False); None: the original commands' choice, True up to 4 cars (the noise
            runs) and False beyond (the 8-car run).
        trainer: the update's settings.
        turns: the original's turning junction, as its lone-car run has it (``"turns": true,
            "learn_right_of_way": true``, ``horizon`` 200 physics steps = 20 decisions): each car
            leaves by one of the three other roads, the lights merged into two phases.
    """

    lidar_noise: float
    seed: int = 0
    epochs: int | None = None
    nagents: int = 4
    balance_cars: bool | None = None
    trainer: TrainerSettings = field(default_factory=TrainerSettings)
    turns: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or not 0 <= self.seed < 2**31:
            raise OriginalError(f"seed must be an integer in [0, 2**31), got {self.seed!r}")
        if not isinstance(self.lidar_noise, (int, float)) or not 0.0 <= self.lidar_noise <= 1.0:
            raise OriginalError(f"lidar_noise must be in [0, 1], got {self.lidar_noise!r}")
        if self.epochs is None and not self.turns and float(self.lidar_noise) not in NOISE_EPOCHS:
            raise OriginalError(f"lidar_noise={self.lidar_noise!r} has no original command: give epochs "
                                f"(the original's are {', '.join(map(str, NOISE_EPOCHS))})")
        if self.epochs is not None and (not isinstance(self.epochs, int) or self.epochs < 1):
            raise OriginalError(f"epochs must be an integer >= 1, got {self.epochs!r}")
        if not isinstance(self.nagents, int) or not 1 <= self.nagents <= 16:
            raise OriginalError(f"nagents must be an integer in [1, 16], got {self.nagents!r}")
        if self.balance_cars is not None and not isinstance(self.balance_cars, bool):
            raise OriginalError(f"balance_cars must be True, False or None, got {self.balance_cars!r}")
        if not isinstance(self.turns, bool):
            raise OriginalError(f"turns must be True or False, got {self.turns!r}")
        t = self.trainer
        if t.steps_per_epoch < t.train_iters or t.train_iters < 1:
            raise OriginalError(f"trainer.steps_per_epoch ({t.steps_per_epoch}) must be at least "
                                f"trainer.train_iters ({t.train_iters}) >= 1")

    @property
    def total_epochs(self) -> int:
        if self.epochs is not None:
            return self.epochs
        return LONE_CAR_EPOCHS if self.turns else NOISE_EPOCHS[float(self.lidar_noise)]

    @property
    def balanced(self) -> bool:
        """Whether the cars' approaches go round robin (the original's ``balance_cars``)."""
        return self.nagents <= 4 if self.balance_cars is None else self.balance_cars

    def spec(self) -> dict[str, Any]:
        """The JSON the worker reads (``run.json``)."""
        return {
            "env": ENV, "seed": self.seed, "epochs": self.total_epochs,
            "env_kwargs": {"horizon": 200 if self.turns else 250, "nagents": self.nagents,
                           "lidar_noise": float(self.lidar_noise), "history_len": 5, "timesteps": 10, "npoints": 100,
                           "turns": self.turns, "learn_right_of_way": self.turns, "default_color": True,
                           "balance_cars": self.balanced},
            "ac_kwargs": {"hidden_sizes": [256, 256], "history_len": 5, "permutation_invariant": True},
            "trainer": asdict(self.trainer),
        }


def lone_car_run() -> dict[str, Any]:
    """The :class:`OriginalRun` settings of the original's 1-car run beside its LiDAR noise, seed
    and epochs: one car on the turning junction, entropy 1e-3."""
    return {"nagents": 1, "turns": True, "trainer": TrainerSettings(entropy_coeff=LONE_CAR_ENTROPY)}
