"""The CTDE policy: the LiDAR encoder's fast paths against the convolution; a centralised critic
blind to teammate order and dead slots, an actor blind to the team."""

import numpy as np
import pytest

th = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import box2d_driving  # noqa: E402
from training.ppo.policy import CTDENetwork, policy_kwargs_for  # noqa: E402
from training.ppo.vec_env import SlotVecEnv  # noqa: E402


@pytest.mark.parametrize("n_rays", [100, 36, 7])
def test_fast_lidar_encoder_equals_the_convolution(n_rays):
    from training.ppo.encoder import LidarEncoder, encode

    th.manual_seed(n_rays)
    encoders = [LidarEncoder(5, n_rays, 4), LidarEncoder(5, n_rays, 4)]
    x = th.randn(50, 5 * n_rays + 20)
    fast, slow = encode(encoders, x), [e.reference(x) for e in encoders]
    params = [p for e in encoders for p in e.parameters()]
    g_fast = th.autograd.grad(sum((o * o).sum() for o in fast), params)
    g_slow = th.autograd.grad(sum((o * o).sum() for o in slow), params)
    for a, b in zip(fast, slow):
        assert th.allclose(a, b, atol=1e-5)
    for a, b in zip(g_fast, g_slow):
        assert th.allclose(a, b, rtol=1e-4, atol=1e-4 * float(b.abs().max()))
    assert not th.allclose(g_fast[0], th.zeros_like(g_fast[0]))


@pytest.mark.parametrize("rows", [50, 2000])  # a rollout step's few rows (the convolutions), an update's many
def test_the_paper_codes_encoder_is_sdrivings_convolutions_and_linear(rows):
    """``lidar_encoder="original"``: sdriving 0.1.0's two convolutions (H -> 1 -> 1 channel, kernel
    4, stride 2, circular padding 2, no activation) pooled to 25, within float rounding on either
    path, gradients too; being linear, it cannot go dead as a ReLU can."""
    from torch import nn

    from training.ppo.encoder import OriginalLidarEncoder, encode

    th.manual_seed(rows)
    enc = OriginalLidarEncoder(5, 100, 4)
    with th.no_grad():  # non-zero biases, so that their path is checked too
        enc.layer1.bias.fill_(0.3)
        enc.layer2.bias.fill_(-0.7)
    sdriving = nn.Sequential(nn.Conv1d(5, 1, 4, 2, 2, padding_mode="circular"),
                             nn.Conv1d(1, 1, 4, 2, 2, padding_mode="circular"), nn.AdaptiveAvgPool1d(25))
    sdriving.load_state_dict({"0.weight": enc.layer1.weight, "0.bias": enc.layer1.bias,
                              "1.weight": enc.layer2.weight, "1.bias": enc.layer2.bias})
    x = th.rand(rows, 5 * 100 + 20)
    out = encode([enc], x)[0]
    assert out.shape == (rows, 25 + 20)
    assert th.allclose(out[:, :25], sdriving(x[:, :500].reshape(rows, 5, 100)).flatten(1), atol=1e-5)
    assert th.equal(out[:, 25:], x[:, 500:])
    params = list(enc.parameters())
    g_fast = th.autograd.grad((encode([enc], x)[0] ** 2).sum(), params)
    g_slow = th.autograd.grad((enc.reference(x) ** 2).sum(), params)
    for a, b in zip(g_fast, g_slow):
        assert th.allclose(a, b, rtol=1e-4, atol=1e-4 * float(b.abs().max()))
    # linear: the features move with the LiDAR whatever the biases (a dead ReLU's would not)
    with th.no_grad():
        enc.layer2.bias.fill_(-1e3)
        assert not th.allclose(enc(x)[:, :25], enc(x * 0.5)[:, :25])
    fresh = OriginalLidarEncoder(5, 100, 4)  # sdriving's init_weights: orthogonal weights, zero biases
    assert not fresh.layer1.bias.any() and not fresh.layer2.bias.any()
    assert th.allclose(fresh.layer1.weight.flatten().norm(), th.tensor(1.0))


@pytest.mark.parametrize("kind", ["relu", "original"])
def test_encoder_without_gradients_equals_the_convolution_and_follows_weight_updates(kind):
    """The rollout's fused no-gradient path (few rows) and the training path (many rows) give the
    reference convolution's values, also after an optimiser step changes the weights it caches
    and after other weights are loaded; for ours and for the paper code's encoder (whose
    no-gradient path is one product with a kept matrix, alone or beside the critic's)."""
    from training.ppo.encoder import FUSED_ROWS, encode, make_encoder

    th.manual_seed(1)
    encoders = [make_encoder(kind, 5, 100, 4), make_encoder(kind, 5, 100, 4)]
    # a linear encoder's squared outputs grow without bound under large steps: a smaller one
    opt = th.optim.SGD([p for e in encoders for p in e.parameters()], lr=0.5 if kind == "relu" else 1e-4)
    before = None
    for rows in (64, FUSED_ROWS + 1):
        x = th.randn(rows, 520)
        for _ in range(2):
            # the step moved the outputs (ours can die under such steps and stop moving: see above)
            if kind == "original" and before is not None and before.shape[0] == rows:
                with th.no_grad():
                    assert not th.allclose(encode(encoders, x)[0], before, atol=1e-3)
            with th.no_grad():
                fast, slow = encode(encoders, x), [e.reference(x) for e in encoders]
                alone = encoders[1](x)
            with th.inference_mode():  # what a rollout step runs in
                inferred = encode(encoders, x)
            for a, b, c in zip(fast, slow, inferred):  # float rounding at the values' own scale
                assert th.allclose(a, b, atol=1e-5 * (1 + float(b.abs().max()))) and th.equal(a, c)
            assert th.allclose(alone, slow[1], atol=1e-5 * (1 + float(slow[1].abs().max())))
            before = fast[0]
            opt.zero_grad()
            sum((o * o).sum() for o in encode(encoders, x)).backward()
            opt.step()  # new weights: the cached fused matrices must not be reused
    other = make_encoder(kind, 5, 100, 4)
    encoders[0].load_state_dict(other.state_dict())  # replaced weights: not the kept matrices either
    with th.no_grad():
        assert th.allclose(encode(encoders, x)[0], other.reference(x), atol=1e-5)


def test_encoder_stand_ins_keep_shapes_and_gradients_and_only_inside_their_block():
    """``bench --train``'s bound: within ``encoders_cost_nothing`` the encoders' outputs keep their
    shapes and pass gradients on; outside it ``encode`` is the convolution again."""
    from training.ppo.encoder import LidarEncoder, encode, encoders_cost_nothing

    th.manual_seed(2)
    encoders = [LidarEncoder(5, 100, 4), LidarEncoder(5, 100, 4)]
    x = th.randn(30, 520)
    with encoders_cost_nothing():
        stand_ins = encode(encoders, x)
    assert [tuple(o.shape) for o in stand_ins] == [(30, e.out_dim) for e in encoders]
    sum(o.sum() for o in stand_ins).backward()
    assert all(e.layer2.bias.grad is not None and e.layer1.weight.grad is None for e in encoders)
    for a, b in zip(encode(encoders, x), [e.reference(x) for e in encoders]):
        assert th.allclose(a, b, atol=1e-5)


def test_critic_encodes_a_repeated_team_once_with_the_same_values():
    th.manual_seed(0)
    net, _ = _network()
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)] * 2)
    venv.seed(3)
    rows = [th.as_tensor(venv.reset())]
    for _ in range(3):
        rows.append(th.as_tensor(venv.step(np.zeros(8, dtype=int))[0]))
    x = th.cat(rows)  # 4 steps x 2 instances x 4 cars, grouped by step
    encoded = []
    net.critic_encoder.register_forward_hook(lambda m, i, o: encoded.append(o.shape[0]))
    grouped = net.forward_critic(x)
    assert encoded == [8 * 4]  # 8 distinct teams of 4 cars, not 32 rows x 4 cars
    one_by_one = th.cat([net.forward_critic(x[i:i + 1]) for i in range(x.shape[0])])
    assert th.allclose(grouped, one_by_one, atol=1e-5)
    interleaved = th.cat([x[0::2], x[1::2]])  # no repeats next to each other
    order = th.cat([th.arange(0, 32, 2), th.arange(1, 32, 2)])
    assert th.allclose(net.forward_critic(interleaved), grouped[order], atol=1e-5)


def _network(critic="mean"):
    env = box2d_driving.make("intersection-v0", num_cars=4)
    kw = policy_kwargs_for(env, critic)
    return CTDENetwork(**kw), SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)])


@pytest.mark.parametrize("critic", ["mean", "own+mean"])
def test_value_is_invariant_to_teammate_order_and_dead_slot_garbage(critic):
    th.manual_seed(0)
    net, venv = _network(critic)
    lay = venv.layout
    x = th.as_tensor(venv.reset())
    # make the cars distinct so the test can fail
    x[:, lay.team] += th.rand(lay.n_cars * lay.obs_dim)
    v = net.forward_critic(x)
    perm = [2, 0, 3, 1]
    team = x[:, lay.team].reshape(-1, 4, lay.obs_dim)
    xp = x.clone()
    xp[:, lay.team] = team[:, perm].reshape(x.shape[0], -1)
    xp[:, lay.alive] = x[:, lay.alive][:, perm]
    assert th.allclose(net.forward_critic(xp), v, atol=1e-5)
    # car 3 dead: garbage in its slot must not matter
    xd = x.clone()
    xd[:, lay.alive.start + 3] = 0
    v_dead = net.forward_critic(xd)
    team = xd[:, lay.team].reshape(-1, 4, lay.obs_dim)
    team[:, 3] = th.randn_like(team[:, 3]) * 1e6
    xd[:, lay.team] = team.reshape(xd.shape[0], -1)
    assert th.allclose(net.forward_critic(xd), v_dead, atol=1e-5)
    assert not th.allclose(v_dead, v, atol=1e-5)  # the mask does matter


def test_own_critic_ignores_the_team():
    th.manual_seed(0)
    net, venv = _network("own")
    lay = venv.layout
    x = th.as_tensor(venv.reset())
    y = x.clone()
    y[:, lay.own.stop:] = th.randn_like(y[:, lay.own.stop:])
    assert th.equal(net.forward_critic(y), net.forward_critic(x))


def test_actor_is_blind_to_the_team_block():
    th.manual_seed(0)
    net, venv = _network()
    lay = venv.layout
    x = th.as_tensor(venv.reset())
    a = net.forward_actor(x)
    y = x.clone()
    y[:, lay.own.stop:] = th.randn_like(y[:, lay.own.stop:]) * 100
    assert th.equal(net.forward_actor(y), a)
    z = x.clone()
    z[:, lay.own] += 0.5
    assert not th.allclose(net.forward_actor(z), a)


def test_the_lean_rollout_forward_is_sb3s_bit_for_bit():
    """The rollout forward pass without distribution objects gives SB3's actions, values and
    log-probabilities exactly, drawing the same random numbers (so rollouts, and the weights
    trained on them, do not change); with gradients on it is SB3's own path."""
    from stable_baselines3.common.utils import obs_as_tensor

    from training.trainers.trainer import TrainConfig, build_model, make_vec_env

    cfg = TrainConfig(env_id="intersection-v0", env_overrides={"num_cars": 3, "lidar_noise": 0.5}, n_envs=4,
                      num_cpus=0)
    venv = make_vec_env(cfg)
    try:
        policy = build_model(cfg, venv).policy
        venv.seed(0)
        obs = obs_as_tensor(venv.reset(), policy.device)
        for deterministic in (False, True):
            got = []
            for lean in (True, False):
                policy.lean_rollouts = lean
                th.manual_seed(11)
                with th.no_grad():
                    got.append(policy(obs, deterministic=deterministic) + (th.rand(3),))  # then the RNG's state
            for a, b in zip(*got):
                assert a.dtype == b.dtype and a.shape == b.shape and th.equal(a, b)
        policy.lean_rollouts = True
        actions, values, log_prob = policy(obs)  # gradients on: SB3's path, differentiable
        assert values.requires_grad and log_prob.requires_grad
    finally:
        venv.close()
