"""The masked rollout buffer: only live transitions, their team rebuilt; whole steps packed into one
minibatch give the values and gradients of full rows."""

import numpy as np
import pytest

th = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import box2d_driving  # noqa: E402
from training.ppo.buffer import MaskedRolloutBuffer  # noqa: E402
from training.ppo.policy import CTDENetwork, policy_kwargs_for  # noqa: E402
from training.ppo.vec_env import SlotVecEnv  # noqa: E402


def _slot_rows(lay, instances, t, alive):
    """Slot observations of ``instances`` instances at step ``t``: each car's own observation is
    ``[t * 100 + slot, 0.5]`` (zeros when dead), the team block and alive flags as the env
    writes them."""
    n = lay.n_cars
    own = np.zeros((instances * n, lay.obs_dim), np.float32)
    own[:, 0] = t * 100 + np.arange(instances * n)
    own[:, 1] = 0.5
    own *= alive[:, None]
    obs = np.zeros((instances * n, lay.size), np.float32)
    for k in range(instances):
        cars = slice(k * n, (k + 1) * n)
        obs[cars, lay.team] = own[cars].reshape(-1)
        obs[cars, lay.alive] = alive[cars]
    obs[:, lay.own] = own
    obs[:, lay.self_alive] = alive
    return obs


def _filled_buffer(steps, instances, cars, group_size, seed=0):
    from gymnasium import spaces

    from training.ppo.slots import TeamLayout, slot_observation_space

    lay = TeamLayout(2, cars)
    space = slot_observation_space(spaces.Box(-1e6, 1e6, (2,), np.float32), cars)
    slots = instances * cars
    buf = MaskedRolloutBuffer(steps, space, spaces.Discrete(2), n_envs=slots, layout=lay,
                              group_size=group_size, gae_lambda=0.9, gamma=0.9)
    rng = np.random.default_rng(seed)
    alive = (rng.random((steps, slots)) < 0.7).astype(np.float32)
    full = []
    for t in range(steps):
        full.append(_slot_rows(lay, instances, t, alive[t]))
        buf.add(full[-1], np.zeros((slots, 1)), np.ones(slots), np.zeros(slots), th.zeros(slots), th.zeros(slots))
    buf.compute_returns_and_advantage(th.zeros(slots), np.zeros(slots))
    return buf, lay, alive, np.stack(full)


def test_masked_buffer_yields_only_live_transitions_with_their_team_rebuilt():
    buf, lay, alive, full = _filled_buffer(steps=4, instances=2, cars=3, group_size=1)
    batches = list(buf.get(batch_size=5))
    rows = np.concatenate([b.observations.numpy() for b in batches])
    assert rows.shape[1] == lay.size  # full slot observations, the team block rebuilt
    ids = rows[:, 0].astype(int)
    expected = [t * 100 + s for t in range(4) for s in range(6) if alive[t, s]]
    assert sorted(ids.tolist()) == sorted(expected)  # each live transition once, no padding
    for row, i in zip(rows, ids):
        np.testing.assert_array_equal(row, full[i // 100, i % 100])
    assert buf.n_valid == int(alive.sum())


def test_masked_buffer_by_step_packs_whole_steps_into_one_minibatch():
    steps, instances, cars = 6, 3, 3
    buf, lay, alive, _ = _filled_buffer(steps, instances, cars, group_size=cars, seed=1)
    seen, batches = [], list(buf.get(batch_size=4))
    for batch in batches[:-1]:  # cut after the step that reaches 4 rows, never inside one
        assert 4 <= len(batch.observations) < 4 + cars
    for batch in batches:
        rows = batch.observations.numpy()
        assert rows.shape[1] == lay.obs_dim + 1  # packed: own observation and group number
        ids, group = rows[:, 0].astype(int), rows[:, -1].astype(int)
        assert group[0] == 0 and np.all(np.diff(group) >= 0) and np.all(np.diff(group) <= 1)
        for g in np.unique(group):
            members = ids[group == g]
            steps_of = {(v // 100, (v % 100) // cars) for v in members}  # (t, instance)
            assert len(steps_of) == 1
            t, k = steps_of.pop()
            live = [t * 100 + k * cars + i for i in range(cars) if alive[t, k * cars + i]]
            assert sorted(members.tolist()) == live  # the group is the step's whole live team
        seen.extend(ids.tolist())
    expected = [t * 100 + s for t in range(steps) for s in range(instances * cars) if alive[t, s]]
    assert sorted(seen) == sorted(expected)  # each live transition exactly once


@pytest.mark.parametrize("critic", ["mean", "own+mean", "own"])
def test_packed_rows_give_the_values_and_gradients_of_full_rows(critic):
    """The update's packed path (one encoder pass, team mean over a group's rows) computes what
    the slot-observation path computes, gradients included."""
    th.manual_seed(0)
    env = box2d_driving.make("intersection-v0", num_cars=4)
    net = CTDENetwork(**policy_kwargs_for(env, critic))
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)] * 2)
    venv.seed(2)
    lay, rows = venv.layout, [venv.reset()]
    rng = np.random.default_rng(0)
    for _ in range(40):
        rows.append(venv.step(rng.integers(0, 13, size=8))[0])
    full = th.as_tensor(np.concatenate(rows))
    full = full[full[:, lay.self_alive] > 0.5]  # live rows; a step's team stays together
    steps = full[:, lay.alive].sum(dim=1)
    assert (steps < 4).any()  # some cars have finished: dead slots are in the test
    first = th.ones(len(full), dtype=th.bool)
    first[1:] = (full[1:, lay.team] != full[:-1, lay.team]).any(dim=1)
    packed = th.cat([full[:, lay.own], (th.cumsum(first, 0) - 1)[:, None].float()], dim=1)
    pi_full, vf_full = net(full)
    grads_full = th.autograd.grad((pi_full.sum() + vf_full.square().sum()), list(net.parameters()))
    pi_packed, vf_packed = net(packed)
    grads_packed = th.autograd.grad((pi_packed.sum() + vf_packed.square().sum()), list(net.parameters()))
    assert th.allclose(pi_packed, pi_full, atol=1e-5) and th.allclose(vf_packed, vf_full, atol=1e-5)
    assert th.allclose(net.forward_critic(packed), vf_full, atol=1e-5)
    for g_packed, g_full in zip(grads_packed, grads_full):
        assert th.allclose(g_packed, g_full, rtol=1e-4, atol=1e-4 * float(g_full.abs().max()))


@pytest.mark.parametrize("critic", ["mean", "own+mean"])
def test_a_rollout_step_takes_the_grouped_path_with_the_same_values(critic):
    """Whole instances in slot order (a rollout step) are recognised and give what the general
    path gives, padding slots of finished cars included; anything else takes the general path."""
    th.manual_seed(1)
    env = box2d_driving.make("intersection-v0", num_cars=4)
    net = CTDENetwork(**policy_kwargs_for(env, critic))
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)] * 3)
    venv.seed(5)
    obs, rng, checked_dead = venv.reset(), np.random.default_rng(1), False
    for _ in range(30):
        x = th.as_tensor(obs)
        assert net._whole_instances(x) is not None
        pi, vf = net(x)
        assert th.allclose(pi, net.forward_actor(x), atol=1e-5)
        assert th.allclose(vf, net.forward_critic(x), atol=1e-5)
        checked_dead |= bool((x[:, venv.layout.self_alive] == 0).any())
        obs = venv.step(rng.integers(0, 13, size=12))[0]
    assert checked_dead
    x = th.as_tensor(obs)
    assert net._whole_instances(x[[1, 0, 2, 3] + list(range(4, 12))]) is None  # not in slot order
    assert net._whole_instances(x[:6]) is None


@pytest.mark.parametrize("group_size", [1, 3])
def test_minibatches_hold_the_transitions_sb3s_slot_major_layout_gives_in_its_order(group_size):
    """The buffer draws minibatches as SB3's flattened (slot-major) layout orders the transitions,
    without copying the arrays into that layout: the same transitions in the same order (so the
    same weights) as the copy gave, whatever the draw."""
    steps, instances, cars = 5, 2, 3
    buf, _, alive, _ = _filled_buffer(steps, instances, cars, group_size=group_size, seed=2)
    np.random.seed(7)
    ids = np.concatenate([b.observations.numpy()[:, 0] for b in buf.get(batch_size=4)]).astype(int).tolist()
    # the order SB3's layout gives: flat index slot * T + t, live ones shuffled (whole steps together)
    np.random.seed(7)
    live = alive.T.reshape(-1) > 0.5
    if group_size == 1:
        valid = np.flatnonzero(live)
        order = valid[np.random.permutation(len(valid))]
    else:
        groups = np.random.permutation(instances * steps)
        instance, t = np.divmod(groups, steps)
        flat = (instance[:, None] * cars + np.arange(cars)[None, :]) * steps + t[:, None]
        order = flat[live[flat]]
    slot, t = np.divmod(order, steps)
    assert ids == (t * 100 + slot).tolist()


def test_the_observations_keep_their_memory_from_update_to_update():
    buf, *_ = _filled_buffer(steps=4, instances=2, cars=3, group_size=3)
    before = buf.observations
    list(buf.get(batch_size=4))
    buf.reset()
    assert buf.observations is before and not before.any()  # the same block, zeroed
    assert buf.observations.shape == (4, 6, buf.obs_shape[0]) and buf.pos == 0 and not buf.full


def test_rewards_to_go_are_the_lambda_returns_of_lambda_one_and_cut_at_episode_ends():
    from gymnasium import spaces
    from stable_baselines3.common.buffers import RolloutBuffer

    from training.ppo.buffer import discounted_returns

    # by hand: one env, rewards 1, 2, 3, an episode starting at step 2, bootstrap value 10
    r = discounted_returns(np.array([[1.0], [2.0], [3.0]]), np.array([[1.0], [0.0], [1.0]]), np.array([10.0]),
                           np.array([0.0]), 0.5)
    assert r[:, 0].tolist() == [1 + 0.5 * 2, 2.0, 3 + 0.5 * 10]
    assert discounted_returns(np.array([[3.0]]), np.zeros((1, 1)), np.array([10.0]), np.array([1.0]), 0.5)[0, 0] == 3
    rng = np.random.default_rng(1)
    steps, envs = 40, 6
    sb3 = RolloutBuffer(steps, spaces.Box(-1, 1, (2,)), spaces.Discrete(2), n_envs=envs, gae_lambda=1.0, gamma=0.9)
    starts = rng.random((steps, envs)) < 0.15
    for t in range(steps):
        sb3.add(np.zeros((envs, 2)), np.zeros((envs, 1)), rng.normal(size=envs), starts[t],
                th.as_tensor(rng.normal(size=envs)), th.zeros(envs))
    last, dones = th.as_tensor(rng.normal(size=envs)), (rng.random(envs) < 0.3).astype(np.float32)
    sb3.compute_returns_and_advantage(last, dones)
    ours = discounted_returns(sb3.rewards, sb3.episode_starts, last.numpy(), dones, 0.9)
    assert np.allclose(ours, sb3.returns, atol=1e-5)


def test_the_masked_buffer_trains_its_critic_on_rewards_to_go_when_asked():
    from gymnasium import spaces

    from training.ppo.buffer import discounted_returns
    from training.ppo.slots import TeamLayout, slot_observation_space

    lay = TeamLayout(2, 2)
    space = slot_observation_space(spaces.Box(-1e6, 1e6, (2,), np.float32), 2)
    rng = np.random.default_rng(2)
    rewards, values = rng.normal(size=(5, 4)), rng.normal(size=(5, 4))
    buffers = []
    for to_go in (False, True):
        buf = MaskedRolloutBuffer(5, space, spaces.Discrete(2), n_envs=4, layout=lay, gae_lambda=0.9, gamma=0.9,
                                  returns_to_go=to_go)
        for t in range(5):
            obs = _slot_rows(lay, 2, t, np.ones(4, np.float32))
            buf.add(obs, np.zeros((4, 1)), rewards[t], np.zeros(4), th.as_tensor(values[t]), th.zeros(4))
        buf.compute_returns_and_advantage(th.ones(4), np.zeros(4))
        buffers.append(buf)
    lam, to_go = buffers
    assert np.array_equal(lam.advantages, to_go.advantages)  # the actor's advantages: GAE either way
    assert np.allclose(lam.returns, lam.advantages + lam.values)  # SB3's lambda-returns
    assert np.allclose(to_go.returns, discounted_returns(rewards, np.zeros((5, 4)), np.ones(4), np.zeros(4), 0.9))
    assert not np.allclose(to_go.returns, lam.returns)
