"""One SB3 ``VecEnv`` slot per car: the parameter-shared multi-agent env as a batch of
single-agent transitions, with done on the right step and the team block for the critic,
vectorised by SuperSuit in the learner's process or across worker processes.

* slot ``k * N + i`` is car ``i`` of env instance ``k``;
* a car's slot reports ``done`` on exactly the decision its trajectory ends, with its real last
  observation in ``infos[slot]["terminal_observation"]`` and ``"TimeLimit.truncated"`` set when the
  horizon (not a goal or a crash) ended it;
* after that the slot emits padding (zero observation, zero reward, alive flag 0) until every car
  of the instance is done and the instance resets; :class:`training.ppo.buffer.MaskedRolloutBuffer`
  keeps padding out of the loss and the advantage normalisation;
* each observation carries a team block, the observations of every car of the same instance and
  their alive mask, so the centralised critic sees the team while PPO shuffles single transitions
  (the actor is built blind to it).

:class:`InstanceSlots` does this for one instance; :class:`SlotVecEnv` concatenates instances with
SuperSuit and adapts the result to SB3 (see its docstring for what the adapter fixes). SuperSuit's
own PettingZoo path (``pettingzoo_env_to_vec_env_v1`` + ``black_death_v3``) is not used: it needs
``black_death_v3`` for cars that finish at different times, which ends episodes on ``terminated
AND truncated`` and never reports a car's own termination.

Layout of a slot observation (:class:`training.ppo.slots.TeamLayout`): ``[own obs (D) | team obs (N x D) | alive (N) |
own alive (1)]``.
"""

from __future__ import annotations

import functools
import weakref
from typing import Any, Callable, Optional, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv
from supersuit.vector import ConcatVecEnv
from supersuit.vector.constructors import call_wrap

from training.ppo.shared_workers import SharedWorkers
from training.ppo.slots import TeamLayout, checked_actions, clear_slot, slot_observation_space, slot_rows
from training.ppo.workers import WorkerSlots, worker_processes, worker_runs

# How worker processes exchange each step with the learner (``--transport``).
TRANSPORTS = ("shared", "supersuit")


class CarSlots(VecEnv):
    """The ``VecEnv`` plumbing shared by every one-slot-per-car vector env: slot ``k * N + i`` is
    car ``i`` of instance ``self.envs[k]`` (needs ``envs`` and ``n_cars``)."""

    n_cars: int

    @property
    def envs(self) -> list:
        """The env instances, one per ``n_cars`` slots (given by the class this is mixed into)."""
        raise NotImplementedError

    def close(self) -> None:
        for e in self.envs:
            e.close()

    def _instances(self, indices) -> list[int]:
        return sorted({i // self.n_cars for i in self._get_indices(indices)})

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self.envs[i // self.n_cars], attr_name) for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        for k in self._instances(indices):
            setattr(self.envs[k], attr_name, value)

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list[Any]:
        return [getattr(self.envs[i // self.n_cars], method_name)(*args, **kwargs)
                for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


class InstanceSlots(gym.vector.VectorEnv):
    """The car slots of one env instance as a Gymnasium-style vector env (``num_envs`` = cars),
    the unit SuperSuit concatenates, in the learner's process or in its worker processes.

    As SuperSuit's concatenation expects, ``observation_space`` / ``action_space`` are one slot's.
    ``step`` returns per slot: termination (a goal or a crash) and truncation (the horizon) apart,
    each finishing car's real last observation in ``infos[i]["terminal_observation"]`` with
    ``"TimeLimit.truncated"``, and padding (zero observation and reward, empty info) after a car is
    done until every car is, when the instance resets itself. ``index`` is the instance's place in
    the whole vector: its first episode's seed is ``seed_base + index`` whatever process it runs in.
    """

    metadata: dict[str, Any] = {"render_modes": []}
    render_mode = None

    def __init__(self, env_fn: Callable[[], Any], index: int) -> None:
        self.env = env_fn()
        self.index = index
        self.agents = list(self.env.possible_agents)
        self.n_cars = len(self.agents)
        base_space = self.env.observation_space(self.agents[0])
        self.layout = TeamLayout(int(np.prod(base_space.shape)), self.n_cars)
        self.num_envs = self.n_cars
        self.observation_space = self.single_observation_space = slot_observation_space(base_space, self.n_cars)
        self.action_space = self.single_action_space = self.env.action_space(self.agents[0])
        self._slot = {a: i for i, a in enumerate(self.agents)}

    def _rows(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """Slot observations from the agents' observation dict (padding for absent agents)."""
        own = np.zeros((self.n_cars, self.layout.obs_dim), dtype=np.float32)
        alive = np.zeros(self.n_cars, dtype=np.float32)
        if obs:
            slots = [self._slot[a] for a in obs]
            own[slots] = np.stack(list(obs.values()))
            alive[slots] = 1.0
        return slot_rows(own[None], alive[None], self.layout)[0]

    def _without(self, rows: np.ndarray, gone: list[int]) -> np.ndarray:
        """``rows`` with the slots ``gone`` turned to padding (as :meth:`_rows` would write them
        without those agents)."""
        rows = rows.copy()
        for i in gone:
            clear_slot(rows, i, self.layout)
        return rows

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        # SuperSuit adds worker and position offsets to ``seed``; the one that counts comes in options
        options = dict(options or {})
        base = options.pop("slot_seed_base", None)
        obs, _ = self.env.reset(seed=None if base is None else base + self.index,
                                **({"options": options} if options else {}))
        return self._rows(obs), [{} for _ in range(self.n_cars)]

    def step(self, actions):
        n = self.n_cars
        actions = np.asarray(actions).reshape(n).tolist()
        rewards = np.zeros(n, dtype=np.float32)
        terms = np.zeros(n, dtype=bool)
        truncs = np.zeros(n, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(n)]  # distinct dicts
        env = self.env
        acts = {a: int(actions[self._slot[a]]) for a in env.agents}
        obs, rew, term, trunc, info = env.step(acts)
        final = self._rows(obs)
        gone = []
        for agent in obs:
            i = self._slot[agent]
            rewards[i] = rew[agent]
            slot_info = info[agent]  # the env's own fresh dict: no copy needed
            if term[agent] or trunc[agent]:
                terms[i] = bool(term[agent])
                truncs[i] = bool(trunc[agent] and not term[agent])
                slot_info["terminal_observation"] = final[i].copy()
                slot_info["TimeLimit.truncated"] = bool(truncs[i])
                gone.append(i)
            infos[i] = slot_info
        if env.agents:
            rows = self._without(final, gone) if gone else final
        else:
            rows = self._rows(env.reset()[0])
        return rows, rewards, terms, truncs, infos

    def close(self, **kwargs: Any) -> None:
        self.env.close()

    def env_is_wrapped(self, wrapper_class: type, indices=None) -> list[bool]:
        return [False] * self.n_cars


class ConcatSlots(ConcatVecEnv):
    """SuperSuit's ``ConcatVecEnv`` whose step runs every instance through one env-core decision.

    SuperSuit steps its sub-envs one after the other and concatenates through Gymnasium's space
    utilities, which walk the batch one row at a time. Here every instance that has live cars is
    stepped by one :func:`box2d_driving.envs.core.step_instances` call (the numpy work of all
    cars of all instances together), and the slot batch (observations with their team blocks,
    rewards, terminations, truncations, infos) is built as whole arrays; instances whose cars are
    all done reset themselves as :class:`InstanceSlots` does. Everything else (reset, seeding,
    closing, how worker processes drive it) is SuperSuit's; ``tests/test_vec_env.py`` checks that
    steps return exactly what SuperSuit's ``ConcatVecEnv`` over the same instances returns.
    """

    def concat_obs(self, observations: Sequence[np.ndarray]) -> np.ndarray:
        return np.concatenate(observations, axis=0)

    def step(self, actions):
        from box2d_driving.envs.core import step_instances

        insts: list[InstanceSlots] = self.vec_envs
        first = insts[0]
        n, lay = first.n_cars, first.layout
        k_all = len(insts)
        actions = np.asarray(actions).reshape(k_all, n)
        live = [k for k, inst in enumerate(insts) if inst.env.agents]
        envs = [insts[k].env for k in live]
        raws = [checked_actions(actions[k, env._acting], first.action_space.n) for k, env in zip(live, envs)]
        decisions = step_instances(envs, raws) if envs else []

        own = np.zeros((k_all, n, lay.obs_dim), dtype=np.float32)
        alive = np.zeros((k_all, n), dtype=np.float32)
        rewards = np.zeros((k_all, n), dtype=np.float32)
        terms = np.zeros((k_all, n), dtype=bool)
        truncs = np.zeros((k_all, n), dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(k_all * n)]  # distinct dicts
        finished = []  # (instance, car) of every car whose trajectory ended now
        for k, d in zip(live, decisions):
            own[k, d.cars] = d.observations
            alive[k, d.cars] = 1.0
            rewards[k, d.cars] = d.rewards
            terms[k, d.cars] = d.terminated
            truncs[k, d.cars] = d.truncated & ~d.terminated
            for i, info in zip(d.cars.tolist(), d.infos):
                infos[k * n + i] = info
            ended = d.cars if d.truncated else d.cars[d.terminated]
            finished += [(k, i) for i in ended.tolist()]
        rows = slot_rows(own, alive, lay)
        for k, i in finished:  # their last observation, then padding in their slots from now on
            info = infos[k * n + i]
            info["terminal_observation"] = rows[k, i].copy()
            info["TimeLimit.truncated"] = bool(truncs[k, i])
        for k, i in finished:  # in place: the batch is a few MB, rebuilding it costs a copy
            clear_slot(rows[k], i, lay)
        for k in live:
            if not insts[k].env.agents:  # every car of the instance is done: it starts over
                rows[k] = insts[k].reset()[0]
        return (rows.reshape(k_all * n, lay.size), rewards.reshape(-1), terms.reshape(-1),
                truncs.reshape(-1), infos)


class SlotVecEnv(CarSlots, VecEnv):
    """``len(env_fns) * num_cars`` slots over parameter-shared driving envs, as an SB3 ``VecEnv``.

    Built on SuperSuit: each instance is an :class:`InstanceSlots`, concatenated by SuperSuit's
    ``ConcatVecEnv`` (as :class:`ConcatSlots`) in the learner's process (``num_cpus=0``) or, split
    as ``supersuit.concat_vec_envs_v1`` splits them, in ``num_cpus`` worker processes that step
    their instances: ``transport="shared"`` (:class:`training.ppo.shared_workers.SharedWorkers`:
    every per-step array in shared memory, a car's full info only at its end) or ``"supersuit"``
    (SuperSuit's ``ProcConcatVec``, which pickles every car's info each step). This
    adapter fixes what SuperSuit's SB3 wrapper gets wrong for us (each fix has a test in
    ``tests/test_vec_env.py``):

    * seeding: ``seed(s)`` gives instance ``k`` the seed ``s + k`` at the next reset, whatever the
      number of workers (SuperSuit's ``reset(seed)`` adds worker and position offsets, so seeds
      would collide and depend on the worker count; its SB3 wrapper has no ``seed`` at all);
    * truncations stay truncations (``TimeLimit.truncated``, set per slot by ``InstanceSlots``);
    * every slot gets its own info dict (SuperSuit's worker path shares one ``{}`` among slots);
    * ``get_attr`` / ``set_attr`` / ``env_method`` reach the env instances in-process; with workers,
      ``get_attr`` answers from a local probe instance (static attributes: config, layout) and the
      others raise, since a live object cannot be set in another process;
    * SuperSuit's row-by-row concatenation of each step's batches is done as whole arrays
      (:class:`ConcatSlots`), and its worker path does not deep-copy each step's infos
      (:class:`WorkerSlots`);
    * ``close()`` ends the workers, and is also called when the adapter is garbage-collected or
      the interpreter exits, so a forgotten ``close()`` cannot hang the interpreter.

    ``black_death_v3`` is not used: it ends an episode on ``terminated AND truncated`` and never
    reports a car's own termination; :class:`InstanceSlots` pads finished cars itself.
    """

    def __init__(self, env_fns: Sequence[Callable[[], Any]], num_cpus: int = 0, transport: str = "shared") -> None:
        if isinstance(num_cpus, bool) or not isinstance(num_cpus, int) or num_cpus < 0:
            raise ValueError(f"num_cpus must be an integer >= 0, got {num_cpus!r}")
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {', '.join(TRANSPORTS)}, got {transport!r}")
        self.transport = transport
        self.num_cpus = min(num_cpus, len(env_fns))
        self.worker_processes = worker_processes(len(env_fns), num_cpus)
        self.probe = InstanceSlots(env_fns[0], 0)  # spaces, layout and static attributes
        self.agents, self.n_cars, self.layout = self.probe.agents, self.probe.n_cars, self.probe.layout
        fns = [functools.partial(InstanceSlots, fn, k) for k, fn in enumerate(env_fns)]
        spaces_ = (self.probe.observation_space, self.probe.action_space)
        if self.num_cpus == 0:
            fns[0] = functools.partial(_same, self.probe)  # in-process, the probe is instance 0
            self._inner = ConcatSlots(fns, *spaces_)
            if any(list(inst.agents) != self.agents for inst in self._inner.vec_envs):
                raise ValueError("all env instances must have the same agents")
        else:
            self._inner = _workers(fns, self.probe, self.num_cpus, transport)
        super().__init__(len(env_fns) * self.n_cars, *spaces_)
        self._seed_base: Optional[int] = None
        self.seed_range: Any = None  # a training.common.seeds.SeedRange every seed must lie in, if set
        self.bootstrap_truncation = True  # False: SB3 sees the horizon as terminal (no bootstrapped value)
        self._finalizer = weakref.finalize(self, _close_inner, self._inner)

    # -- instances ----------------------------------------------------------------------------
    def _local_instances(self) -> list[InstanceSlots]:
        if self.num_cpus:
            raise RuntimeError("the env instances live in worker processes (--num-cpus > 0); "
                               "this needs them in the learner's process (--num-cpus 0)")
        return list(self._inner.vec_envs)

    @property
    def envs(self) -> list:
        """The env instances (in the learner's process only)."""
        return [inst.env for inst in self._local_instances()]

    # -- VecEnv API ---------------------------------------------------------------------------
    def seed(self, seed: Optional[int] = None) -> list[Optional[int]]:
        n_instances = self.num_envs // self.n_cars
        if seed is not None and self.seed_range is not None:
            self.seed_range.episodes(n_instances, seed)
        self._seed_base = seed
        return [None if seed is None else seed + k for k in range(n_instances)]

    def reset(self):
        options = None if self._seed_base is None else {"slot_seed_base": self._seed_base}
        obs, _ = self._inner.reset(seed=None, options=options)
        self._seed_base = None
        return np.asarray(obs, dtype=np.float32)

    def step_async(self, actions: np.ndarray) -> None:
        self._inner.step_async(np.asarray(actions).reshape(self.num_envs))

    def step_wait(self):
        obs, rewards, terms, truncs, infos = self._inner.step_wait()
        dones = np.asarray(terms, dtype=bool) | np.asarray(truncs, dtype=bool)
        infos = _unshared(infos)
        if not self.bootstrap_truncation:  # the horizon as a terminal state (the paper's code)
            for info in infos:
                if info.get("TimeLimit.truncated"):
                    info["TimeLimit.truncated"] = False
        return np.asarray(obs, dtype=np.float32), np.asarray(rewards, dtype=np.float32), dones, infos

    def close(self) -> None:
        self._finalizer()
        self.probe.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        if self.num_cpus:  # static attributes: every instance has the probe's
            return [getattr(self.probe.env, attr_name) for _ in self._get_indices(indices)]
        return super().get_attr(attr_name, indices)


def _unshared(infos: Sequence[dict]) -> list[dict]:
    """One dict per slot: a dict that appears a second time (SuperSuit's worker path hands every
    empty slot the same ``{}``) is copied."""
    seen: set[int] = set()
    out = []
    for info in infos:
        if id(info) in seen:
            info = dict(info)
        seen.add(id(info))
        out.append(info)
    return out


def _same(obj: Any) -> Any:
    return obj


def _close_inner(inner: Any) -> None:
    inner.close()


def _workers(fns: list, probe: InstanceSlots, num_cpus: int, transport: str = "shared") -> Any:
    """The instances over :func:`training.ppo.workers.worker_processes` worker processes, each
    stepping its run of instances as one :class:`ConcatSlots`; with one worker too (SuperSuit's
    constructor keeps a single CPU in the learner's process, but the user asked for a worker).
    ``transport``: ``shared`` (:class:`training.ppo.shared_workers.SharedWorkers`) or ``supersuit``
    (its ``ProcConcatVec``, as :class:`training.ppo.workers.WorkerSlots`)."""
    runs = worker_runs(fns, num_cpus)
    if transport == "shared":
        return SharedWorkers([call_wrap(ConcatSlots, run) for run in runs],
                             [len(run) * probe.n_cars for run in runs], probe.layout.size)
    return WorkerSlots([call_wrap(ConcatSlots, run) for run in runs], probe.observation_space,
                       probe.action_space, len(fns) * probe.n_cars, probe.metadata)


def make_vec_env_from(env_id: str, overrides: dict, n_envs: int, num_cpus: int = 0,
                      spline_policy: Optional[Callable[[np.ndarray], np.ndarray]] = None,
                      transport: str = "shared") -> SlotVecEnv:
    """``n_envs`` instances of a registered env as one :class:`SlotVecEnv` (module-level factory:
    worker processes receive it pickled). ``spline_policy`` becomes every spline scenario
    instance's path picker; with workers it must be callable there (see ``training.ppo.shared_policy``)."""
    factory = functools.partial(_make_env, env_id, overrides, spline_policy)
    return SlotVecEnv([factory] * n_envs, num_cpus, transport)


def _make_env(env_id: str, overrides: dict, spline_policy: Any = None) -> Any:
    import box2d_driving

    env = box2d_driving.make(env_id, **overrides)
    if spline_policy is not None:
        env.spline_policy = spline_policy
    return env


def make_slot_vec_env(env_id: str, n_envs: int, num_cpus: int = 0, transport: str = "shared",
                      **overrides: Any) -> SlotVecEnv:
    """``n_envs`` instances of a registered env as one :class:`SlotVecEnv`."""
    return make_vec_env_from(env_id, overrides, n_envs, num_cpus, transport=transport)
