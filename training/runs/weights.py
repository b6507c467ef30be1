"""Start a model from a checkpoint trained on a related env (``--init-from``).

Same observation layout and action count: a plain copy (e.g. a 4-car policy fine-tuned with 8
cars, as the paper does). A target whose sat-nav has extra fields (the communication option's
``bit_received``) and whose action space is the communication one (``n_accelerations x 2``): the
copy is *widened* so the new model starts out as the old policy, exactly:

* the first layer after each encoder (actor MLP, critic projection) reads the pooled LiDAR features
  and the sat-nav history; columns of the sat-nav fields both layouts have are copied by
  ``(frame, field name)``, columns of new fields start at zero (ignored until learnt);
* action ``a + n * bit`` gets the logit row of acceleration ``a``: the same acceleration policy,
  with the bit a fair coin.
"""

from __future__ import annotations

import json
from pathlib import Path

import torch as th

import box2d_driving

# Layers whose input is an encoder's output ``[pooled LiDAR | sat-nav history]``.
_ENCODER_READERS = ("mlp_extractor.actor_mlp.0.weight", "mlp_extractor.critic_proj.0.weight")
_ACTION_HEAD = ("action_net.weight", "action_net.bias")


class WeightsError(ValueError):
    """The checkpoint's network cannot be carried over to this model."""


def weights_encoder(state: dict[str, th.Tensor]) -> str:
    """The LiDAR encoder a policy's weights were built with: ``original`` (the paper code's: its
    second convolution is ``conv.1``, with no ReLU between) or ``relu`` (ours: ``conv.2``)."""
    original = any(k.endswith("actor_encoder.conv.1.weight") for k in state)
    return "original" if original else "relu"


def source_fields(checkpoint_dir: Path) -> tuple[str, ...]:
    """Sat-nav field names of the env a checkpoint folder was trained on (from its config.json)."""
    path = checkpoint_dir / "config.json"
    if not path.exists():
        raise WeightsError(f"{checkpoint_dir} has no config.json: cannot tell its observation layout")
    saved = json.loads(path.read_text())
    env = box2d_driving.make(saved["env_id"], **saved["env_overrides"])
    return env.observation_layout.satnav_fields


def widen_state_dict(mine: dict[str, th.Tensor], theirs: dict[str, th.Tensor], *,
                     src_fields: tuple[str, ...], dst_fields: tuple[str, ...],
                     history: int) -> dict[str, th.Tensor]:
    """``theirs`` reshaped to ``mine``'s shapes as the module docstring says (a new dict)."""
    out = {}
    n_src, n_dst = len(src_fields), len(dst_fields)
    missing = [f for f in src_fields if f not in dst_fields]
    if missing:
        raise WeightsError(f"the target sat-nav lacks {missing}: cannot carry those inputs over")
    for key, target in mine.items():
        source = theirs[key]
        if source.shape == target.shape:
            out[key] = source.clone()
        elif key in _ENCODER_READERS:
            pooled = source.shape[1] - history * n_src
            if pooled != target.shape[1] - history * n_dst or source.shape[0] != target.shape[0]:
                raise WeightsError(f"{key}: {tuple(source.shape)} does not map onto {tuple(target.shape)}")
            w = th.zeros_like(target)
            w[:, :pooled] = source[:, :pooled]
            for f in range(history):
                for i, name in enumerate(src_fields):
                    w[:, pooled + f * n_dst + dst_fields.index(name)] = source[:, pooled + f * n_src + i]
            out[key] = w
        elif key in _ACTION_HEAD and target.shape[0] % source.shape[0] == 0 \
                and source.shape[1:] == target.shape[1:]:
            n = source.shape[0]
            out[key] = source[th.arange(target.shape[0]) % n].clone()
        else:
            raise WeightsError(f"{key}: {tuple(source.shape)} vs {tuple(target.shape)}")
    return out
