"""Emergent communication (the paper's turn signals) from rollout tables recorded with
``communication=True``.

A car's bit sent on decision ``t`` travels with its action of decision ``t`` (table row ``t``);
its *next action* is the acceleration it applies on decision ``t + 1`` (row ``t + 1``), and its
heading change is ``heading(t + 1) - heading(t)``.

* Speaker consistency: the mutual information (bits) between the sent bit and the next action.
* Pearson correlation between the heading change and the bit (signed, as the paper), and between
  the absolute heading change and the bit (a "turn signal" that says *that* a car turns, not
  which way, shows up there).
* What each bit value says: per value, its share and the sender's mean speed (m/s, on decision
  ``t``), mean next acceleration (m/s^2) and mean absolute heading change (rad).
* Turn signal: the heading change over one decision is near zero until a car is in its turn, so
  a bit sent *before* turning shows up only against the car's whole route. Route turn = heading
  on arrival - heading on the first decision (rad, left > 0), for cars that reached their goal;
  movement = left / right beyond ``STRAIGHT_WITHIN`` of straight. Reported: Pearson(route turn,
  bit), the mutual information (bits) between the bit and the movement, and the share of bit 1
  per movement, over the decisions those cars sent a bit on.
"""

from __future__ import annotations

import numpy as np

from box2d_driving.metrics.lanes import pearson
from box2d_driving.road.geometry import wrap_angle


def mutual_information(a: np.ndarray, b: np.ndarray) -> float:
    """Mutual information (bits) between two discrete samples of equal length."""
    a, b = np.asarray(a), np.asarray(b)
    if len(a) == 0:
        return float("nan")
    _, ai = np.unique(a, return_inverse=True)
    _, bi = np.unique(b, return_inverse=True)
    joint = np.zeros((ai.max() + 1, bi.max() + 1))
    np.add.at(joint, (ai, bi), 1.0)
    joint /= joint.sum()
    pa, pb = joint.sum(axis=1, keepdims=True), joint.sum(axis=0, keepdims=True)
    nz = joint > 0
    return float(np.sum(joint[nz] * np.log2(joint[nz] / (pa @ pb)[nz])))


def message_pairs(table: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per (car, decision t) with a row at ``t + 1``: ``row`` (of t), ``bit`` (sent at t), ``next_accel``,
    ``heading_change`` (rad, wrapped) and, when the table has speeds, ``speed`` (m/s, at t)."""
    if "bit_sent" not in table or np.all(np.isnan(table["bit_sent"])):
        raise ValueError("the rollouts carry no sent bits: record them with communication=True")
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car, dec = table["episode"][order], table["car"][order], table["decision"][order]
    nxt = (ep[1:] == ep[:-1]) & (car[1:] == car[:-1]) & (dec[1:] == dec[:-1] + 1)
    now, later = order[:-1][nxt], order[1:][nxt]
    bits = table["bit_sent"][now]
    keep = (table["decision"][now] >= 1) & ~np.isnan(bits)  # row 0 is the reset: nothing sent yet
    now, later, bits = now[keep], later[keep], bits[keep]
    dh = table["heading"][later] - table["heading"][now]
    out = {"row": now, "bit": bits.astype(np.int64), "next_accel": np.round(table["acceleration"][later], 6),
           "heading_change": wrap_angle(dh)}
    if "speed" in table:
        out["speed"] = table["speed"][now]
    return out


def communication_metrics(table: dict[str, np.ndarray]) -> dict:
    """Every message measure of the module docstring from a rollout table: the share of bit 1,
    speaker consistency (bits), the two heading-change correlations, what each bit value says of
    its sender (``by_bit``) and the turn-signal measures."""
    p = message_pairs(table)
    return {
        "samples": int(len(p["bit"])),
        "bit_one_share": float(np.mean(p["bit"])) if len(p["bit"]) else float("nan"),
        "speaker_consistency_bits": mutual_information(p["bit"], p["next_accel"]),
        "pearson_heading_change_bit": pearson(p["heading_change"], p["bit"]),
        "pearson_abs_heading_change_bit": pearson(np.abs(p["heading_change"]), p["bit"]),
        "by_bit": {str(v): _bit_profile(p, p["bit"] == v) for v in (0, 1)},
        "turn_signal": turn_signal_metrics(table, p),
    }


STRAIGHT_WITHIN = np.pi / 6  # rad: a route turning less than this either way is "straight"
MOVEMENTS = ("right", "straight", "left")


def route_turns(table: dict[str, np.ndarray]) -> np.ndarray:
    """Per row, the route turn (rad, left > 0) of its car: heading on the car's last row minus on
    its first; NaN for cars that did not reach their goal."""
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car = table["episode"][order], table["car"][order]
    is_first = np.ones(len(order), dtype=bool)
    is_first[1:] = (ep[1:] != ep[:-1]) | (car[1:] != car[:-1])
    is_last = np.append(is_first[1:], True)
    first, last = order[is_first], order[is_last]
    turn = np.where(table["arrived"][last].astype(bool),
                    wrap_angle(table["heading"][last] - table["heading"][first]), np.nan)
    per_row = np.empty(len(order))
    per_row[order] = turn[np.cumsum(is_first) - 1]  # each sorted row's car
    return per_row


def turn_signal_metrics(table: dict[str, np.ndarray], pairs: dict[str, np.ndarray] | None = None) -> dict:
    """Does the bit say which way the sender's route turns? (module docstring)."""
    p = message_pairs(table) if pairs is None else pairs
    turn = route_turns(table)[p["row"]]
    known = ~np.isnan(turn)
    turn, bit = turn[known], p["bit"][known]
    movement = np.where(turn > STRAIGHT_WITHIN, 2, np.where(turn < -STRAIGHT_WITHIN, 0, 1))
    return {
        "samples": int(known.sum()),
        "pearson_route_turn_bit": pearson(turn, bit),
        "movement_bit_mi_bits": mutual_information(bit, movement),
        "bit_one_share_by_movement": {name: float(np.mean(bit[movement == k])) if (movement == k).any()
                                      else float("nan") for k, name in enumerate(MOVEMENTS)},
    }


def _bit_profile(pairs: dict[str, np.ndarray], sent: np.ndarray) -> dict[str, float]:
    """Share of the samples that sent this value, and the sender's means over them."""
    def mean(x: np.ndarray) -> float:
        return float(np.mean(x[sent])) if sent.any() else float("nan")
    out = {"share": float(np.mean(sent)) if len(sent) else float("nan"),
           "next_accel_mean": mean(pairs["next_accel"]),
           "abs_heading_change_mean": mean(np.abs(pairs["heading_change"]))}
    if "speed" in pairs:
        out["speed_mean"] = mean(pairs["speed"])
    return out


def average_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..n of ``x``; tied values share the mean of their ranks."""
    x = np.asarray(x, dtype=float)
    order = np.argsort(x, kind="stable")
    ranks = np.empty(len(x))
    ranks[order] = np.arange(1, len(x) + 1)
    for v in np.unique(x):
        tied = x == v
        ranks[tied] = ranks[tied].mean()
    return ranks


def rank_trend(x: np.ndarray, y: np.ndarray, max_exact: int = 8, permutations: int = 20_000,
               seed: int = 0) -> dict[str, float]:
    """Does ``y`` rise with ``x``? Spearman's rho and its one-sided permutation p-value: the
    share of reorderings of ``y`` against ``x`` whose rho is at least the observed one (all
    ``n!`` for ``n <= max_exact`` points, else ``permutations`` draws from a generator seeded
    with ``seed``). Used across runs (several seeds per noise level) for the paper's "rises with
    noise"; with few runs the p-value can't be small (n = 4 points: at best 1/24)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) != len(y):
        raise ValueError(f"rank_trend needs paired samples, got {len(x)} x and {len(y)} y values")
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return {"n": int(len(x)), "spearman": float("nan"), "p_rises": float("nan")}
    rx, ry = average_ranks(x), average_ranks(y)
    rx, ry = rx - rx.mean(), ry - ry.mean()
    scale = np.sqrt((rx @ rx) * (ry @ ry))
    rho = float(rx @ ry / scale)
    if len(x) <= max_exact:
        from itertools import permutations as all_orders
        shuffled = np.array(list(all_orders(ry)))
    else:
        rng = np.random.default_rng(seed)
        shuffled = np.array([rng.permutation(ry) for _ in range(permutations)])
    null = shuffled @ rx / scale
    return {"n": int(len(x)), "spearman": rho, "p_rises": float(np.mean(null >= rho - 1e-12))}
