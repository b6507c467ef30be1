"""The training half of a named preset (the world half is :mod:`box2d_driving.presets`).

``paper``: the update of the paper's own trainer (sdriving 0.1.0, ``ppo_distributed``, as its
experiment list runs it) as far as SB3's options reach: 20 env instances, an update every 32,000
*joint* steps (each step one decision of every car of an instance still in its episode: with the
preset's cars that stay after arriving, 32,000 x ``num_cars`` slot-decisions), one pass over them
in 20 minibatches of whole steps, entropy 1e-4, the value clipped to +-0.2 around its rollout
estimate, learning rate 1e-3, gamma 0.99, GAE lambda 0.97, clip 0.2, target KL 0.2; past the KL
limit only the actor stops, advantages normalised per car over the update, Adam's epsilon 1e-8,
no gradient clipping, the horizon terminal (:mod:`training.ppo.original_update`), and its
network's LiDAR encoder (two linear strided convolutions to one channel,
:class:`training.ppo.encoder.OriginalLidarEncoder`). What still
differs is tabled in the docs' page "Our world and the paper's".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional

from box2d_driving.config import ConfigError

if TYPE_CHECKING:
    from training.trainers.trainer import TrainConfig


@dataclass(frozen=True)
class TrainingPreset:
    """Training settings a preset sets (fields of :class:`~training.trainers.trainer.TrainConfig`,
    the update's size given in joint steps).

    Attributes:
        n_envs: env instances (the original's 20 Horovod workers, one instance each).
        joint_steps_per_update: joint env steps per update, over all instances (``-se``).
        minibatches: minibatches in the update's one pass (``-ti``).
        epochs: passes over the update's data.
        ent_coef: entropy bonus (``--entropy-coeff``).
        clip_range_vf: the value estimate is clipped to this around the rollout's.
        learning_rate, gamma, gae_lambda, clip_range, target_kl: as the original command.
        kl_stop: ``"actor"``: past the KL limit only the actor stops (the critic trains on).
        advantage_normalisation: ``"per_car"``: over the update, per car index.
        value_targets: ``"rewards_to_go"``: the critic learns discounted rewards (``ret_buf``).
        adam_eps: Adam's epsilon (``eps=1e-8`` in the original's two Adams).
        max_grad_norm: None: gradients are not clipped (the original does not clip).
        bootstrap_truncation: False: the horizon is terminal (value 0), as the original's
            ``episode_runner`` treats its timeout.
        lidar_encoder: ``"original"``: the LiDAR encoder of the original's actor and critic.
    """

    n_envs: int = 20
    joint_steps_per_update: int = 32_000
    minibatches: int = 20
    epochs: int = 1
    ent_coef: float = 1e-4
    clip_range_vf: float = 0.2
    learning_rate: float = 1e-3
    gamma: float = 0.99
    gae_lambda: float = 0.97
    clip_range: float = 0.2
    target_kl: float = 0.2
    kl_stop: str = "actor"
    advantage_normalisation: str = "per_car"
    value_targets: str = "rewards_to_go"
    adam_eps: float = 1e-8
    max_grad_norm: Optional[float] = None
    bootstrap_truncation: bool = False
    lidar_encoder: str = "original"

    def slot_decisions_per_update(self, num_cars: int) -> int:
        """The update's size in slot-decisions: every car of every joint step."""
        return self.joint_steps_per_update * num_cars

    def minibatch_for(self, batch_decisions: int) -> int:
        """The minibatch that cuts an update of ``batch_decisions`` into this preset's minibatches."""
        return math.ceil(batch_decisions / self.minibatches)

    def apply(self, config: "TrainConfig", num_cars: int) -> None:
        """Set ``config``'s update to this preset's for ``num_cars`` cars per instance."""
        config.n_envs = self.n_envs
        config.batch_decisions = self.slot_decisions_per_update(num_cars)
        config.minibatch = self.minibatch_for(config.batch_decisions)
        config.epochs = self.epochs
        config.ent_coef = self.ent_coef
        config.clip_range_vf = self.clip_range_vf
        config.learning_rate, config.gamma, config.gae_lambda = self.learning_rate, self.gamma, self.gae_lambda
        config.clip_range, config.target_kl = self.clip_range, self.target_kl
        config.kl_stop, config.advantage_normalisation = self.kl_stop, self.advantage_normalisation
        config.value_targets = self.value_targets
        config.adam_eps, config.max_grad_norm = self.adam_eps, self.max_grad_norm
        config.bootstrap_truncation = self.bootstrap_truncation
        config.lidar_encoder = self.lidar_encoder

    def resize(self, config: "TrainConfig", *, n_envs: Optional[int] = None, batch_decisions: Optional[int] = None,
               epochs: Optional[int] = None) -> None:
        """Replace the sizes of ``config`` (set by :meth:`apply`) that are given: a new
        ``batch_decisions`` keeps the minibatch at this preset's share of it, so the update stays
        one pass in :attr:`minibatches` minibatches. ``train`` and ``bench --train`` both resize
        through here."""
        if n_envs is not None:
            config.n_envs = n_envs
        if batch_decisions is not None:
            config.batch_decisions = batch_decisions
            config.minibatch = self.minibatch_for(batch_decisions)
        if epochs is not None:
            config.epochs = epochs


# the lone-car run of the paper's experiment list trains with entropy 1e-3
TRAINING_PRESETS = {"paper": TrainingPreset(), "paper-turns": TrainingPreset(ent_coef=1e-3)}


def training_preset(name: str) -> TrainingPreset:
    if name not in TRAINING_PRESETS:
        raise ConfigError(f"unknown preset {name!r}; presets: {', '.join(TRAINING_PRESETS)}")
    return TRAINING_PRESETS[name]
