"""The env instances of a :class:`training.ppo.vec_env.SlotVecEnv` in worker processes:
SuperSuit's ``ProcConcatVec`` (each worker steps its instances and writes their observations to
shared memory) with two fixes, and how the instances are split among the workers."""

from __future__ import annotations

import os
from typing import Any, Sequence

from supersuit.vector import ProcConcatVec
from supersuit.vector.multiproc_vec import decompress_info


def worker_runs(fns: Sequence[Any], num_cpus: int) -> list[list[Any]]:
    """``fns`` (one per instance) in consecutive runs of ``ceil(len(fns) / num_cpus)``, one run per
    worker process, as SuperSuit's ``MakeCPUAsyncConstructor`` splits them."""
    per_cpu = -(-len(fns) // max(1, min(num_cpus, len(fns))))
    return [list(fns[i:i + per_cpu]) for i in range(0, len(fns), per_cpu)]


def worker_processes(n_envs: int, num_cpus: int) -> int:
    """How many worker processes ``num_cpus`` workers for ``n_envs`` instances start (the runs of
    :func:`worker_runs`): 16 instances over 15 workers are 8 processes of 2 (0: all in the
    learner's process)."""
    if min(num_cpus, n_envs) <= 0:
        return 0
    return len(worker_runs(range(n_envs), num_cpus))


class WorkerSlots(ProcConcatVec):
    """SuperSuit's worker-process vector env without its per-step deep copy of the infos.

    ``ProcConcatVec.step_wait`` deep-copies each step's infos after unpickling them from the
    workers' pipes. Unpickled objects belong to no one else, so the copy only costs time: with 16
    instances of 4 cars, 1.5 ms a step on a 2-core machine, about a third of what one worker
    process added to a step there. The one ``{}`` SuperSuit hands every empty slot is split by
    ``training.ppo.vec_env._unshared``, as before. Everything else is SuperSuit's, but for
    :meth:`close` in a process that did not start the workers.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._owner_pid = os.getpid()
        super().__init__(*args, **kwargs)

    def close(self) -> None:
        """Close the workers, in the process that started them; elsewhere do nothing.

        A process forked while this object still awaited garbage collection (the next vector env's
        workers, when one process builds several in turn) inherits a copy. Its workers are not that
        process's children: SuperSuit's ``close``, called by ``__del__`` when the copy is collected
        there, failed multiprocessing's "can only test a child process" assertion, once per worker.
        """
        if os.getpid() != self._owner_pid:  # set before SuperSuit starts anything
            return
        super().close()

    def step_wait(self):
        infos = decompress_info(self.num_envs, self.idx_starts, self._receive_info())
        obs = self.observations_buffers.copy()  # the workers overwrite the shared buffer next step
        return (obs, self.shared_rews.np_arr.copy(), self.shared_terms.np_arr.astype(bool),
                self.shared_truncs.np_arr.astype(bool), infos)
