"""Worker processes that exchange every per-step array through shared memory: the ``shared``
transport of :class:`training.ppo.vec_env.SlotVecEnv` (``--transport shared``, the default).

SuperSuit's ``ProcConcatVec`` (the ``supersuit`` transport, still selectable) already writes
observations, rewards and done flags to shared memory, but each step it also sends every slot's
action through a pipe as a pickled list, writes the observations one slot at a time, and pickles
every live car's info dict (about twenty entries, a nested dict of reward terms and a position
array) through the pipes. Here:

* actions, observations (the whole slot rows, team blocks included), rewards, terminations,
  truncations and the per-decision info columns a training callback reads (:data:`STEP_INFO_KEYS`:
  is the car live, its light, whether it is in the junction) live in preallocated shared arrays,
  each worker writing its own slice with one array assignment;
* a step is one short message to each worker and one back; the message back carries only the full
  info dicts of the cars whose trajectory ended at that step (with their ``terminal_observation``,
  what SB3, the metrics and the callbacks need), nothing for the other cars;
* a live car's info at any other step is rebuilt in the learner from the shared columns, holding
  just :data:`STEP_INFO_KEYS`; a padding slot's info is ``{}`` as on every path.

The instances of a worker are stepped as one :class:`training.ppo.vec_env.ConcatSlots`, exactly as
in SuperSuit's workers, so both transports give the same observations, rewards and done flags bit
for bit (``tests/test_shared_workers.py``). Workers start as SuperSuit's do (multiprocessing's
default start method: forked on Linux).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time
import traceback
from multiprocessing.connection import Connection
from typing import Any, Callable, Optional, Sequence

import numpy as np

# Info entries every live car reports at every decision on this transport (the progress
# callback's red-light entries read them); the full dict comes only at a car's end.
STEP_INFO_KEYS = ("light", "in_junction")

_CLOSE_SECONDS = 10.0


class _Arrays:
    """Shared arrays of ``slots`` slots of ``width`` float32 each (``RawArray``: no lock, each
    worker writes only its own slice and the learner reads between steps)."""

    def __init__(self, slots: int, width: int, ctx: Any) -> None:
        self.raw = {
            "actions": ctx.RawArray("q", slots),
            "obs": ctx.RawArray("f", slots * width),
            "rewards": ctx.RawArray("f", slots),
            "terms": ctx.RawArray("b", slots),
            "truncs": ctx.RawArray("b", slots),
            "live": ctx.RawArray("b", slots),
            "light": ctx.RawArray("d", slots),
            "in_junction": ctx.RawArray("b", slots),
        }
        self.width = width
        self.views()

    def __getstate__(self) -> dict:  # a spawned worker gets the buffers, not copies of the views
        return {"raw": self.raw, "width": self.width}

    def __setstate__(self, state: dict) -> None:
        self.raw, self.width = state["raw"], state["width"]
        self.views()

    def views(self) -> None:
        """numpy views of the shared buffers."""
        r = self.raw
        self.actions = np.frombuffer(r["actions"], dtype=np.int64)
        self.obs = np.frombuffer(r["obs"], dtype=np.float32).reshape(-1, self.width)
        self.rewards = np.frombuffer(r["rewards"], dtype=np.float32)
        self.terms = np.frombuffer(r["terms"], dtype=np.int8)
        self.truncs = np.frombuffer(r["truncs"], dtype=np.int8)
        self.live = np.frombuffer(r["live"], dtype=np.int8)
        self.light = np.frombuffer(r["light"], dtype=np.float64)
        self.in_junction = np.frombuffer(r["in_junction"], dtype=np.int8)


def _serve(make: Callable[[], Any], start: int, conn: Connection, arrays: _Arrays) -> None:
    """A worker's loop: build its instances, then answer ``reset`` / ``step`` / ``close``."""
    try:
        vec = make()
        end = start + vec.num_envs
        conn.send(vec.num_envs)
        while True:
            cmd, data = conn.recv()
            if cmd == "step":
                obs, rewards, terms, truncs, infos = vec.step(arrays.actions[start:end])
                conn.send(_write(arrays, start, obs, rewards, terms, truncs, infos))
            elif cmd == "reset":
                obs, _ = vec.reset(seed=None, options=data)
                zero = np.zeros(end - start, dtype=bool)
                _write(arrays, start, obs, np.zeros(end - start, np.float32), zero, zero, [{}] * (end - start))
                conn.send(None)
            elif cmd == "close":
                vec.close()
                conn.send(None)
                return
            else:
                raise ValueError(f"unknown command {cmd!r}")
    except KeyboardInterrupt:
        return
    except BaseException as e:  # the learner re-raises it, with the worker's traceback
        try:
            conn.send(("error", f"{type(e).__name__}: {e}", traceback.format_exc()))
        except (BrokenPipeError, OSError):
            pass


def _write(arrays: _Arrays, start: int, obs: np.ndarray, rewards: np.ndarray, terms: np.ndarray,
           truncs: np.ndarray, infos: Sequence[dict]) -> list[tuple[int, dict]]:
    """Write a worker's step into its slice of the shared arrays; return the infos of the cars
    whose trajectory ended now, as ``(slot within the worker, info)``."""
    end = start + len(rewards)
    arrays.obs[start:end] = obs
    arrays.rewards[start:end] = rewards
    arrays.terms[start:end] = terms
    arrays.truncs[start:end] = truncs
    ended = []
    for i, info in enumerate(infos):
        s = start + i
        arrays.live[s] = bool(info)
        if info:
            arrays.light[s] = info.get("light", np.nan)
            arrays.in_junction[s] = bool(info.get("in_junction", False))
            if terms[i] or truncs[i]:
                ended.append((i, info))
    return ended


class SharedWorkers:
    """One worker process per entry of ``makers``, each stepping the vector env its maker builds
    (``slots[w]`` slots of worker ``w``, observations ``width`` float32 wide).

    The inner vector env of :class:`training.ppo.vec_env.SlotVecEnv` with workers: ``reset``,
    ``step_async``, ``step_wait``, ``close``, as SuperSuit's ``ProcConcatVec`` offers them.
    """

    def __init__(self, makers: Sequence[Callable[[], Any]], slots: Sequence[int], width: int,
                 start_method: Optional[str] = None) -> None:
        from gymnasium.vector.async_vector_env import CloudpickleWrapper

        self._owner_pid = os.getpid()
        self.num_envs = int(sum(slots))
        self.starts = [int(x) for x in np.concatenate([[0], np.cumsum(slots)])]
        ctx: Any = mp.get_context(start_method)  # None: multiprocessing's default, as SuperSuit's workers
        self.arrays = _Arrays(self.num_envs, width, ctx)
        self._closed = False
        self.pipes: list[Connection] = []
        self.procs: list[Any] = []
        try:
            for w, make in enumerate(makers):
                ours, theirs = ctx.Pipe()
                proc = ctx.Process(target=_serve, args=(CloudpickleWrapper(make), self.starts[w], theirs, self.arrays),
                                   daemon=True)
                proc.start()
                theirs.close()
                self.pipes.append(ours)
                self.procs.append(proc)
            for w, n in enumerate(slots):  # each worker says how many slots it built
                if self._receive(w) != n:
                    raise ValueError(f"env worker {w} built a different number of slots than {n}")
        except BaseException:
            self.close()
            raise

    def _died(self, w: int) -> RuntimeError:
        self.procs[w].join(1.0)  # its exit code, where it has one
        return RuntimeError(f"env worker {w} (pid {self.procs[w].pid}) died (exit code {self.procs[w].exitcode})")

    def _send(self, w: int, msg: Any) -> None:
        try:
            self.pipes[w].send(msg)
        except (BrokenPipeError, ConnectionResetError) as e:
            raise self._died(w) from e

    def _receive(self, w: int) -> Any:
        try:
            msg = self.pipes[w].recv()
        except (EOFError, ConnectionResetError) as e:
            raise self._died(w) from e
        if isinstance(msg, tuple) and len(msg) == 3 and msg[0] == "error":
            raise RuntimeError(f"env worker {w} failed: {msg[1]}\n{msg[2]}")
        return msg

    def _all(self, cmd: str, data: Any = None) -> list[Any]:
        for w in range(len(self.pipes)):
            self._send(w, (cmd, data))
        return [self._receive(w) for w in range(len(self.pipes))]

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        if seed is not None:
            raise ValueError("seed the instances through options (slot_seed_base), as SlotVecEnv does")
        self._all("reset", options)
        return self.arrays.obs.copy(), [{} for _ in range(self.num_envs)]

    def step_async(self, actions: np.ndarray) -> None:
        self.arrays.actions[:] = actions
        for w in range(len(self.pipes)):
            self._send(w, ("step", None))

    def step_wait(self):
        a = self.arrays
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        ended = [self._receive(w) for w in range(len(self.pipes))]
        live = np.flatnonzero(a.live)
        lights, inside = a.light[live].tolist(), a.in_junction[live].tolist()
        for s, light, ins in zip(live.tolist(), lights, inside):
            infos[s] = {"light": light, "in_junction": bool(ins)}
        for w, items in enumerate(ended):
            for i, info in items:
                infos[self.starts[w] + i] = info
        return (a.obs.copy(), a.rewards.copy(), a.terms.astype(bool), a.truncs.astype(bool), infos)

    def close(self) -> None:
        """Stop the workers (in the process that started them; a forked copy does nothing)."""
        if os.getpid() != self._owner_pid or getattr(self, "_closed", True):
            return
        self._closed = True
        for pipe, proc in zip(self.pipes, self.procs):
            if proc.is_alive():
                try:
                    pipe.send(("close", None))
                except (BrokenPipeError, OSError):
                    pass
        deadline = time.monotonic() + _CLOSE_SECONDS
        for proc in self.procs:
            proc.join(max(0.0, deadline - time.monotonic()))
        for pipe, proc in zip(self.pipes, self.procs):
            if proc.is_alive():
                proc.kill()
                proc.join()
            pipe.close()
