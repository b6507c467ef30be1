"""The paper's actor and centralised critic as an SB3 policy (docs/training.md).

* Actor: LiDAR history ``(H, n_rays)`` -> two circular 1-D convolutions -> average pool to 25
  features (ours, or the paper code's linear ones: ``lidar_encoder``, ``training/ppo/encoder.py``);
  concatenated with the sat-nav history; MLP [256, 256] tanh -> action logits. It reads
  only the slot's own observation: :meth:`CTDENetwork.forward_actor` never touches the team block.
* Critic: the same encoder architecture (own weights) on every car of the env instance in the
  team block -> linear 256 tanh -> mean over live cars (masked: dead slots contribute nothing, so
  any number of cars and any order give the same value) -> MLP 256 tanh -> value. Variant
  ``own+mean`` also concatenates the slot's own 256-d encoding before the MLP; ``own`` is the
  decentralised baseline (plain PPO: the critic sees only the slot's own observation).

Extension goes through SB3's documented hook (``_build_mlp_extractor``); features are the raw
slot observation (``FlattenExtractor``), or during a PPO update by env step the packed rows of
:class:`training.ppo.buffer.MaskedRolloutBuffer` (own observation and group number, see
:meth:`CTDENetwork.forward`). The LiDAR encoders are computed as in ``training/ppo/encoder.py``.
"""

from __future__ import annotations

from typing import Any, Optional, cast

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.type_aliases import PyTorchObs
from torch import nn

from box2d_driving.policies.numpy_actor import HIDDEN
from training.ppo.encoder import (ENCODERS, CircularConv1d, LidarEncoder, encode,  # noqa: F401  (re-exported)
                                  make_encoder)
from training.ppo.original_update import KLWatch

CRITICS = ("mean", "own+mean", "own")


class CTDENetwork(nn.Module):
    """``forward_actor``: own observation only; ``forward_critic``: the team block."""

    def __init__(self, obs_dim: int, n_cars: int, history: int, n_rays: int, n_satnav: int,
                 critic: str = "mean", hidden: int = HIDDEN, lidar_encoder: str = "relu") -> None:
        super().__init__()
        if critic not in CRITICS:
            raise ValueError(f"critic must be one of {CRITICS}, got {critic!r}")
        self.obs_dim, self.n_cars, self.critic = obs_dim, n_cars, critic
        self.latent_dim_pi = hidden
        self.latent_dim_vf = hidden
        self.actor_encoder = make_encoder(lidar_encoder, history, n_rays, n_satnav)
        self.actor_mlp = nn.Sequential(nn.Linear(self.actor_encoder.out_dim, hidden), nn.Tanh(),
                                       nn.Linear(hidden, hidden), nn.Tanh())
        self.critic_encoder = make_encoder(lidar_encoder, history, n_rays, n_satnav)
        self.critic_proj = nn.Sequential(nn.Linear(self.critic_encoder.out_dim, hidden), nn.Tanh())
        width = hidden * (2 if critic == "own+mean" else 1)
        self.critic_mlp = nn.Sequential(nn.Linear(width, hidden), nn.Tanh())

    def forward(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        d = self.obs_dim
        if features.shape[1] == d + 1:  # packed rows of an update by env step
            return self._forward_grouped(features[:, :d], features[:, d].long(), None)
        slots = self._whole_instances(features)
        if slots is not None:  # a rollout step: every slot of every instance, in slot order
            return self._forward_grouped(features[:, :d], *slots)
        return self.forward_actor(features), self.forward_critic(features)

    def _whole_instances(self, features: th.Tensor) -> Optional[tuple[th.Tensor, th.Tensor]]:
        """``(group, alive)`` of slot observations that are whole env instances in slot order
        (row ``k * N + i`` is car ``i`` of instance ``k``, as a rollout step passes them), else
        None. Then each instance's team block is its own rows again, so the critic can read the
        team from the rows the actor encodes."""
        d, n, b = self.obs_dim, self.n_cars, features.shape[0]
        if b % n or b == 0:
            return None
        alive = features[:, d * (1 + n) + n]
        if features.device.type == "cpu" and not features.requires_grad:
            # the same comparisons in numpy: a third of torch's time on these few dozen rows
            rows_np = features.numpy().reshape(b // n, n, -1)
            team = rows_np[:, :, d:d * (1 + n) + n]  # team observations and alive flags
            whole = (bool((team[:, 1:] == team[:, :1]).all())
                     and np.array_equal(team[:, 0, : d * n].reshape(b, d), rows_np[:, :, :d].reshape(b, d))
                     and np.array_equal(team[:, 0, d * n:].reshape(b), rows_np[:, :, -1].reshape(b)))
        else:
            rows = features.reshape(b // n, n, -1)
            block = rows[:, :1, d:]  # team observations, alive flags and own alive of each first slot
            whole = (th.equal(rows[:, :, d:d * (1 + n) + n], block[..., : d * n + n].expand(-1, n, -1))
                     and th.equal(block[:, 0, : d * n].reshape(b, d), features[:, :d])
                     and th.equal(block[:, 0, d * n: d * n + n].reshape(b), alive))
        if not whole:
            return None
        return th.arange(b, device=features.device) // n, alive

    def _forward_grouped(self, own: th.Tensor, group: th.Tensor,
                         alive: Optional[th.Tensor]) -> tuple[th.Tensor, th.Tensor]:
        """Latents of rows ``own`` (observations, D) whose teams are groups of rows: ``group``
        numbers them 0, 1, ... in order, ``alive`` (None: all) says which rows count in their
        team's mean. Packed update rows (:class:`training.ppo.buffer.MaskedRolloutBuffer` by env step)
        and whole instances of a rollout step come this way: both encoders run once, together,
        on the same rows, and the critic averages each group's encodings."""
        latent_pi, pending = self._actor_first(own, group, alive)
        return latent_pi, self.critic_latent(pending)

    def _actor_first(self, own: th.Tensor, group: th.Tensor,
                     alive: Optional[th.Tensor]) -> tuple[th.Tensor, tuple]:
        """The actor's latent of grouped rows, and what :meth:`critic_latent` finishes the
        critic's from (its encodings, computed with the actor's in one fused pass)."""
        actor_in, critic_in = encode([self.actor_encoder, self.critic_encoder], own)
        return self.actor_mlp(actor_in), ("grouped", critic_in, group, alive)

    def actor_latent(self, features: th.Tensor) -> tuple[th.Tensor, tuple]:
        """A rollout step in two halves: the actor's latent of ``features`` (slot observations or
        packed rows) and a pending critic computation for :meth:`critic_latent`, which gives
        exactly what :meth:`forward` gives as the critic's latent. The overlapped rollout loop
        (:mod:`training.ppo.overlapped`) steps the envs between the two."""
        d = self.obs_dim
        if features.shape[1] == d + 1:
            return self._actor_first(features[:, :d], features[:, d].long(), None)
        slots = self._whole_instances(features)
        if slots is not None:
            return self._actor_first(features[:, :d], *slots)
        return self.forward_actor(features), ("slots", features)

    def critic_latent(self, pending: tuple) -> th.Tensor:
        """The critic's latent of the rows :meth:`actor_latent` left ``pending``."""
        if pending[0] == "slots":
            return self.forward_critic(pending[1])
        _, critic_in, group, alive = pending
        z = self.critic_proj(critic_in)
        if self.critic == "own":
            return self.critic_mlp(z)
        n_groups = int(group[-1]) + 1
        live = z if alive is None else z * alive[:, None]
        sums = z.new_zeros(n_groups, z.shape[1]).index_add_(0, group, live)
        counts = th.bincount(group, weights=alive, minlength=n_groups).to(z.dtype)
        mean = sums / counts.clamp(min=1)[:, None]
        if self.critic == "mean":  # one value per team: the MLP runs once per group
            return self.critic_mlp(mean).index_select(0, group)
        return self.critic_mlp(th.cat([z, mean.index_select(0, group)], dim=1))

    def forward_actor(self, features: th.Tensor) -> th.Tensor:
        return self.actor_mlp(self.actor_encoder(features[:, : self.obs_dim]))

    def forward_critic(self, features: th.Tensor) -> th.Tensor:
        d, n = self.obs_dim, self.n_cars
        if features.shape[1] == d + 1:
            return self.forward(features)[1]
        b = features.shape[0]
        if self.critic == "own":
            return self.critic_mlp(self.critic_proj(self.critic_encoder(features[:, :d])))
        block = features[:, d: d * (1 + n) + n]  # team observations and alive mask
        # Rows of one env step carry the same block: encode each run of repeats once.
        first = th.ones(b, dtype=th.bool)
        first[1:] = (block[1:] != block[:-1]).any(dim=1)
        unique = block[first]
        u = unique.shape[0]
        team = unique[:, : d * n].reshape(u * n, d)
        alive = unique[:, d * n:] > 0.5
        z = self.critic_proj(self.critic_encoder(team)).reshape(u, n, -1)
        z = th.where(alive[..., None], z, th.zeros((), dtype=z.dtype))
        mean = z.sum(dim=1) / alive.sum(dim=1, keepdim=True).clamp(min=1)
        if u < b:
            mean = mean[th.cumsum(first, 0) - 1]
        if self.critic == "own+mean":
            own = self.critic_proj(self.critic_encoder(features[:, :d]))
            mean = th.cat([own, mean], dim=1)
        return self.critic_mlp(mean)


class CTDEPolicy(ActorCriticPolicy):
    """Decentralised actor, centralised mean-latent critic (SB3 ``ActorCriticPolicy``)."""

    # SB3 types this as its MlpExtractor and lets a subclass build its own (_build_mlp_extractor)
    mlp_extractor: CTDENetwork  # type: ignore[assignment]

    def __init__(self, *args: Any, obs_dim: int, n_cars: int, history: int, n_rays: int,
                 n_satnav: int, critic: str = "mean", lidar_encoder: str = "relu", **kwargs: Any) -> None:
        self.ctde_kwargs: dict[str, Any] = dict(obs_dim=obs_dim, n_cars=n_cars, history=history, n_rays=n_rays,
                                n_satnav=n_satnav, critic=critic, lidar_encoder=lidar_encoder)
        super().__init__(*args, **kwargs)

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = CTDENetwork(**self.ctde_kwargs)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(self.ctde_kwargs)
        return data

    kl_watch: Optional[KLWatch] = None  # when the paper's KL rule is on
    # rollouts take the lean forward pass below (False: SB3's own, e.g. to compare the two)
    lean_rollouts = True

    def forward(self, obs: th.Tensor, deterministic: bool = False) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """Actions, values and log-probabilities of a rollout step, as SB3's ``forward`` computes
        them, bit for bit and drawing the same random numbers, without building a distribution
        object (its argument checks and wrappers cost about a fifth of the step's forward pass on
        64 rows): the logits are normalised, sampled from and read exactly as
        ``torch.distributions.Categorical`` does. Anything that needs gradients, and action spaces
        other than one discrete choice, take SB3's path. Computed as :meth:`rollout_actions`
        then :meth:`rollout_values`, the two halves the overlapped rollout loop calls apart."""
        if not self.lean_forward_applies():
            return super().forward(obs, deterministic)
        actions, log_prob, pending = self.rollout_actions(obs, deterministic)
        return actions, self.rollout_values(pending), log_prob

    def lean_rollouts_available(self) -> bool:
        """Whether rollouts may take the lean path (it is on, and the action is one discrete choice)."""
        return self.lean_rollouts and isinstance(self.action_space, spaces.Discrete)

    def lean_forward_applies(self) -> bool:
        """Whether :meth:`forward` takes the lean path (no gradients, and it is available)."""
        return not th.is_grad_enabled() and self.lean_rollouts_available()

    def rollout_actions(self, obs: th.Tensor, deterministic: bool = False) -> tuple[th.Tensor, th.Tensor, tuple]:
        """The first half of the lean :meth:`forward`: actions and their log-probabilities (rows,),
        and the pending critic work for :meth:`rollout_values` (no gradients)."""
        latent_pi, pending = self.mlp_extractor.actor_latent(cast(th.Tensor, self.extract_features(obs)))
        logits = self.action_net(latent_pi)
        logits = logits - logits.logsumexp(dim=-1, keepdim=True)  # Categorical(logits=...) normalises so
        probs = th.softmax(logits, dim=-1)
        if deterministic:
            actions = th.argmax(probs, dim=1)
        else:
            actions = th.multinomial(probs, 1, True).T.reshape(-1)
        log_prob = logits.gather(-1, actions.unsqueeze(-1)).squeeze(-1)
        return actions, log_prob, pending  # (rows,): a Discrete action is one number

    def rollout_values(self, pending: tuple) -> th.Tensor:
        """The second half of the lean :meth:`forward`: the values (rows, 1) of the step whose
        actions :meth:`rollout_actions` drew."""
        return self.value_net(self.mlp_extractor.critic_latent(pending))

    def evaluate_actions(self, obs: PyTorchObs, actions: th.Tensor
                         ) -> tuple[th.Tensor, th.Tensor, Optional[th.Tensor]]:
        values, log_prob, entropy = super().evaluate_actions(obs, actions)
        if self.kl_watch is not None:  # PPO's update: the KL of this minibatch, before its step
            self.kl_watch.measure(log_prob)
        return values, log_prob, entropy

    def actor_parameters(self) -> list[th.nn.Parameter]:
        """The actor's parameters: its encoder and MLP and the action head (the critic's are
        separate, so the two can be stepped apart)."""
        net = self.mlp_extractor
        return [*net.actor_encoder.parameters(), *net.actor_mlp.parameters(), *self.action_net.parameters()]


def policy_kwargs_for(env: Any, critic: str = "mean", lidar_encoder: str = "relu") -> dict[str, Any]:
    """``policy_kwargs`` for :class:`CTDEPolicy` from a driving env (its observation layout)."""
    lay = env.observation_layout
    return dict(obs_dim=lay.size, n_cars=len(env.possible_agents), history=lay.history,
                n_rays=lay.n_rays, n_satnav=lay.n_satnav, critic=critic, lidar_encoder=lidar_encoder)
