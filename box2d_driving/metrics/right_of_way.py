"""Right of way (first in, first out) and safe following distance from rollout tables.

Right of way, first in first out: ``t_a(i)`` is the first decision car ``i`` is inside the junction
area and ``t_d(i)`` the first decision after that on which it is outside again (``inf`` if its
trajectory ends inside, e.g. it crashed there). Car ``i`` violates FIFO if some car ``j`` of the
same episode entered after it (``t_a(i) < t_a(j)``) but left before it (``t_d(j) < t_d(i)``).
Times are decisions (1 s), so cars entering or leaving on the same decision are never ordered.

Safe distance: a sample is a car still driving at the end of a decision (not arrived, not
collided on it). Its leader is the nearest other car *present in the world* at that moment whose
centre lies within ``half_angle`` of the car's heading and that travels the same way (headings
less than ``same_way`` apart: the car is *trailing* it; an oncoming car in the next lane is not a
leader). Present means driving, or halted after a collision when wrecks stay in the world (they
keep their last pose, at speed 0, for the rest of the episode although they have no rows after
it); a car that arrived on a decision left the world during it, so its last row (its pose on
arrival) is nobody's leader. ``gap`` = centre distance - car length (bumper to bumper when
aligned), closing speed ``dv`` = the rate at which the centre distance shrinks. Samples with
``dv > 0`` count; one is safe if ``gap >= dv^2 / (2 a_max)``.
"""

from __future__ import annotations

import math

import numpy as np

from box2d_driving.metrics.pedestrians import stopping_distance
from box2d_driving.road.geometry import wrap_angle


def junction_times(table: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """One row per car that entered the junction: ``episode``, ``car``, ``t_a``, ``t_d``."""
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car, dec = table["episode"][order], table["car"][order], table["decision"][order]
    inside = table["in_junction"][order].astype(bool)
    out: dict[str, list] = {"episode": [], "car": [], "t_a": [], "t_d": []}
    start = 0
    n = len(order)
    while start < n:
        stop = start
        while stop < n and ep[stop] == ep[start] and car[stop] == car[start]:
            stop += 1
        ins = np.flatnonzero(inside[start:stop])
        if len(ins):
            first = ins[0]
            after = np.flatnonzero(~inside[start + first:stop])
            out["episode"].append(int(ep[start]))
            out["car"].append(int(car[start]))
            out["t_a"].append(float(dec[start + first]))
            out["t_d"].append(float(dec[start + first + after[0]]) if len(after) else math.inf)
        start = stop
    return {"episode": np.array(out["episode"], dtype=np.int64), "car": np.array(out["car"], dtype=np.int64),
            "t_a": np.array(out["t_a"]), "t_d": np.array(out["t_d"])}


def fifo_violations(t_a: np.ndarray, t_d: np.ndarray) -> np.ndarray:
    """Whether each car of one episode violates FIFO (someone entered after it, left before it)."""
    t_a, t_d = np.asarray(t_a, float), np.asarray(t_d, float)
    later_in = t_a[:, None] < t_a[None, :]
    earlier_out = t_d[None, :] < t_d[:, None]
    return np.any(later_in & earlier_out, axis=1)


def fifo_metrics(table: dict[str, np.ndarray]) -> dict:
    """Share of cars that went into the junction with no FIFO violation, overall and as mean
    +- std over episodes (episodes with at least two such cars).

    Two readings of the paper's definition: ``fifo_share`` counts every car that entered (one that
    never leaves, a wreck in the junction, violates whenever a later car leaves: ``t_d`` is
    infinite); ``fifo_share_leaving`` counts only the cars that left the junction, each against the
    others that left."""
    times = junction_times(table)
    ok = np.zeros(len(times["car"]), dtype=bool)
    leaving_ok: list[bool] = []
    per_episode = []
    for e in np.unique(times["episode"]):
        idx = np.flatnonzero(times["episode"] == e)
        v = fifo_violations(times["t_a"][idx], times["t_d"][idx])
        ok[idx] = ~v
        left = idx[np.isfinite(times["t_d"][idx])]
        leaving_ok += (~fifo_violations(times["t_a"][left], times["t_d"][left])).tolist()
        if len(idx) >= 2:
            per_episode.append(float(np.mean(~v)))
    return {
        "cars_through_junction": int(len(ok)),
        "fifo_share": float(np.mean(ok)) if len(ok) else float("nan"),
        "cars_leaving_junction": len(leaving_ok),
        "fifo_share_leaving": float(np.mean(leaving_ok)) if leaving_ok else float("nan"),
        "fifo_share_episode_mean": float(np.mean(per_episode)) if per_episode else float("nan"),
        "fifo_share_episode_std": float(np.std(per_episode)) if per_episode else float("nan"),
        "episodes": len(per_episode),
    }


def leader_samples(table: dict[str, np.ndarray], car_length: float, half_angle: float = math.pi / 6,
                   same_way: float = math.pi / 2, wrecks_stay: bool = True) -> dict[str, np.ndarray]:
    """Per driving row with a leader within ``half_angle`` ahead: ``gap`` (m), ``closing_speed``
    (m/s), ``speed`` (m/s), ``row`` (index into the table), ``leader_halted`` (the leader is a
    wreck: a car halted by its collision). ``wrecks_stay``: collided cars stay in the world as
    halted obstacles (``DrivingConfig.remove_collided`` false)."""
    n = len(table["episode"])
    arrived = table.get("arrived", np.zeros(n, dtype=bool)).astype(bool)
    collided = table.get("collided", np.zeros(n, dtype=bool)).astype(bool)
    present = ~arrived & (~collided | wrecks_stay)
    ent = {k: table[k][present] for k in ("episode", "decision", "x", "y", "heading", "speed")}
    ent["row"] = np.flatnonzero(present)
    ent["follower"] = ~collided[present]
    if wrecks_stay and collided.any():
        ent = _with_wrecks(ent, table, np.flatnonzero(collided))
    key = ent["episode"].astype(np.int64) * 1_000_003 + ent["decision"].astype(np.int64)
    order = np.argsort(key, kind="stable")
    bounds = np.flatnonzero(np.diff(key[order])) + 1
    rows, gaps, closing, speeds, halted = [], [], [], [], []
    for group in np.split(order, bounds):
        if len(group) < 2:
            continue
        pos = np.stack([ent["x"][group], ent["y"][group]], axis=1)
        head = ent["heading"][group]
        speed = ent["speed"][group]
        vel = speed[:, None] * np.stack([np.cos(head), np.sin(head)], axis=1)
        rel = pos[None, :, :] - pos[:, None, :]  # i -> j
        dist = np.linalg.norm(rel, axis=2)
        bearing = np.arctan2(rel[..., 1], rel[..., 0]) - head[:, None]
        bearing = wrap_angle(bearing)
        turn = np.abs(wrap_angle(head[None, :] - head[:, None]))
        ahead = (np.abs(bearing) <= half_angle) & (dist > 0) & (turn < same_way)
        dist_ahead = np.where(ahead, dist, np.inf)
        lead = np.argmin(dist_ahead, axis=1)
        has = np.isfinite(dist_ahead[np.arange(len(group)), lead]) & ent["follower"][group]
        for i in np.flatnonzero(has):
            j = lead[i]
            u = rel[i, j] / dist[i, j]
            rows.append(ent["row"][group[i]])
            gaps.append(max(dist[i, j] - car_length, 0.0))
            closing.append(float((vel[i] - vel[j]) @ u))
            speeds.append(float(speed[i]))
            halted.append(not ent["follower"][group[j]])
    return {"row": np.array(rows, dtype=np.int64), "gap": np.array(gaps), "closing_speed": np.array(closing),
            "speed": np.array(speeds), "leader_halted": np.array(halted, dtype=bool)}


def _with_wrecks(ent: dict[str, np.ndarray], table: dict[str, np.ndarray],
                 crash_rows: np.ndarray) -> dict[str, np.ndarray]:
    """Add each wreck (its pose on the collision row, speed 0) as a leader-only entry on every
    later decision of its episode, up to the episode's last recorded decision."""
    ep, dec = table["episode"], table["decision"]
    episode_end = {e: int(dec[ep == e].max()) for e in np.unique(ep[crash_rows]).tolist()}
    later = [np.arange(dec[r] + 1, episode_end[int(ep[r])] + 1) for r in crash_rows.tolist()]
    rows = np.repeat(crash_rows, [len(t) for t in later])
    wrecks = {"episode": ep[rows], "decision": np.concatenate(later), "x": table["x"][rows],
              "y": table["y"][rows], "heading": table["heading"][rows], "speed": np.zeros(len(rows)),
              "row": rows, "follower": np.zeros(len(rows), dtype=bool)}
    return {k: np.concatenate([ent[k], wrecks[k].astype(ent[k].dtype)]) for k in ent}


def safety_distance_metrics(table: dict[str, np.ndarray], a_max: float, car_length: float,
                            half_angle: float = math.pi / 6, wrecks_stay: bool = True) -> dict:
    """Share of closing samples (``dv > 0``) with ``gap >= dv^2 / (2 a_max)``."""
    samples = leader_samples(table, car_length, half_angle, wrecks_stay=wrecks_stay)
    return safety_distance_from_samples(samples, a_max)


def closing_samples(s: dict[str, np.ndarray], a_max: float) -> dict[str, np.ndarray]:
    """The closing samples (``dv > 0``) of :func:`leader_samples` ``s``: their ``closing_speed``,
    ``gap``, ``row`` and ``leader_halted``, the distance ``need``-ed to shed ``dv`` at ``a_max``
    and whether each is ``safe`` (``gap >= need``)."""
    closing = s["closing_speed"] > 0
    out = {k: s[k][closing] for k in ("closing_speed", "gap", "row", "leader_halted")}
    out["need"] = stopping_distance(out["closing_speed"], a_max)
    out["safe"] = out["gap"] >= out["need"]
    return out


def safety_distance_from_samples(s: dict[str, np.ndarray], a_max: float) -> dict:
    """:func:`safety_distance_metrics` of samples already drawn by :func:`leader_samples`.

    Besides the share over all closing samples (the paper's measure), the closing samples whose leader is a
    wreck are counted and the share is also given without them (``safe_share_moving_leader``):
    a car closing on a crash that just happened ahead of it is the pile-up case, which human
    driving data (the paper's 99.56 %) hardly contains."""
    c = closing_samples(s, a_max)
    safe, halted = c["safe"], c["leader_halted"]
    return {
        "samples_with_leader": int(len(s["gap"])),
        "closing_samples": int(len(safe)),
        "safe_share": float(np.mean(safe)) if len(safe) else float("nan"),
        "gap_median": float(np.median(s["gap"])) if len(s["gap"]) else float("nan"),
        "closing_samples_halted_leader": int(halted.sum()),
        "unsafe_samples_halted_leader": int((halted & ~safe).sum()),
        "safe_share_moving_leader": float(np.mean(safe[~halted])) if (~halted).any() else float("nan"),
    }


# closing-speed classes (m/s) the unsafe samples are counted in
CLOSING_CLASSES = ((0.0, 2.0), (2.0, 4.0), (4.0, 6.0), (6.0, math.inf))
SOON = 3  # decisions: "collides soon" means within this many decisions of the sample


def unsafe_breakdown(table: dict[str, np.ndarray], s: dict[str, np.ndarray], a_max: float,
                     car_length: float) -> dict:
    """Where the unsafe closing samples of :func:`leader_samples` ``s`` come from, and the share
    under readings of the definition that the paper's text leaves open.

    * ``by_leader``: the car ahead is a wreck (halted by its collision, still in the world) or
      moving;
    * ``by_closing_speed``: counts per class of :data:`CLOSING_CLASSES` (m/s);
    * ``by_outcome``: what becomes of the follower: it collides within :data:`SOON` decisions of
      the sample, collides later, or never (arrives or runs out of time);
    * ``safe_share_every_leader_sample``: the share when every sample with a car ahead counts,
      an opening or steady gap (``dv <= 0``) being safe by the definition (no speed to shed);
    * ``safe_share_centre_distance``: the share when the distance is between centres, as a
      LiDAR-free "distance between agents" reads, not bumper to bumper.
    """
    c = closing_samples(s, a_max)
    dv, gap, rows, need, halted = c["closing_speed"], c["gap"], c["row"], c["need"], c["leader_halted"]
    unsafe = ~c["safe"]
    crash = {}  # (episode, car) -> decision of its collision
    collided = table.get("collided", np.zeros(len(table["episode"]), dtype=bool)).astype(bool)
    for r in np.flatnonzero(collided).tolist():
        crash[(int(table["episode"][r]), int(table["car"][r]))] = int(table["decision"][r])
    until = np.array([crash.get((int(table["episode"][r]), int(table["car"][r])), math.inf)
                      - int(table["decision"][r]) for r in rows[unsafe].tolist()], dtype=float)
    n_leader = len(s["gap"])
    return {
        "unsafe_samples": int(unsafe.sum()),
        "by_leader": {"wreck": int((unsafe & halted).sum()), "moving": int((unsafe & ~halted).sum())},
        "by_closing_speed": {(f"{lo:g}-{hi:g}" if math.isfinite(hi) else f">={lo:g}"):
                             int((unsafe & (dv >= lo) & (dv < hi)).sum()) for lo, hi in CLOSING_CLASSES},
        "by_outcome": {f"collides_within_{SOON}": int((until <= SOON).sum()),
                       "collides_later": int(((until > SOON) & np.isfinite(until)).sum()),
                       "no_collision": int(np.isinf(until).sum())},
        "safe_share_every_leader_sample": (float((n_leader - unsafe.sum()) / n_leader) if n_leader
                                           else float("nan")),
        "safe_share_centre_distance": (float(np.mean(gap + car_length >= need)) if len(gap)
                                       else float("nan")),
    }
