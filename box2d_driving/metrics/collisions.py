"""What the collisions were: each collided car classified by what it hit and where.

A collided car has exactly one row with ``collided`` set: the decision of its first collision (it
halts there and takes no more decisions). Classes:

- ``edge``, ``pedestrian``: it hit a road edge or a pedestrian;
- ``wreck``: it hit a car that had already halted after an earlier collision (a static, visible
  obstacle: by default wrecks stay in the world);
- two moving cars, by the angle between their headings at the crash: ``same_way`` (less than
  ``same_way`` apart: rear-ends, or two cars merging into one lane), ``oncoming`` (more than
  ``oncoming`` apart: head-on, e.g. a turn across oncoming traffic), ``crossing`` (between).

Each class also counts how many of its cars crashed inside the junction area.
:func:`wreck_collision_room` asks of each ``wreck`` crash whether braking could have avoided it.
"""

from __future__ import annotations

import math

import numpy as np

from box2d_driving.metrics.pedestrians import stopping_distance
from box2d_driving.metrics.rollouts import COLLIDED_WITH, COLLISION_COLUMNS, row_lookup
from box2d_driving.road.geometry import wrap_angle

CLASSES = ("same_way", "crossing", "oncoming", "wreck", "edge", "pedestrian")


def collision_classes(table: dict[str, np.ndarray], same_way: float = math.pi / 6,
                      oncoming: float = 5 * math.pi / 6) -> dict[str, np.ndarray]:
    """Per collided car: ``row`` (its crash row) and ``kind`` (index into :data:`CLASSES`).
    Angles in radians."""
    missing = [c for c in COLLISION_COLUMNS if c not in table]
    if missing:
        raise KeyError(f"rollout table lacks {missing}: it was recorded before collision partners "
                       "were; evaluate the policy again to classify its collisions")
    rows = np.flatnonzero(table["collided"].astype(bool))
    with_ = table["collided_with"][rows]
    kind = np.full(len(rows), -1, dtype=np.int64)
    kind[with_ == COLLIDED_WITH.index("edge")] = CLASSES.index("edge")
    kind[with_ == COLLIDED_WITH.index("pedestrian")] = CLASSES.index("pedestrian")
    car = with_ == COLLIDED_WITH.index("car")
    halted = table["partner_halted"][rows].astype(bool)
    kind[car & halted] = CLASSES.index("wreck")
    # the moving partner also collided on this decision: its crash row holds its heading then
    moving = np.flatnonzero(car & ~halted)
    r = rows[moving]
    partner_rows = row_lookup(table)(table["episode"][r], table["collision_partner"][r], table["decision"][r])
    for n, pr in zip(moving.tolist(), partner_rows.tolist()):
        if pr < 0 or not table["collided"][pr]:
            raise ValueError(f"row {rows[n]}: car {table['car'][rows[n]]} hit moving car "
                             f"{table['collision_partner'][rows[n]]}, which has no crash row on that decision")
        diff = abs(float(wrap_angle(table["heading"][pr] - table["heading"][rows[n]])))
        kind[n] = CLASSES.index("same_way" if diff < same_way else "oncoming" if diff > oncoming
                                else "crossing")
    return {"row": rows, "kind": kind}


def collision_breakdown(table: dict[str, np.ndarray], same_way: float = math.pi / 6,
                        oncoming: float = 5 * math.pi / 6) -> dict:
    """Collided cars per class (:data:`CLASSES`) and how many of each crashed in the junction."""
    c = collision_classes(table, same_way, oncoming)
    inside = table["in_junction"][c["row"]].astype(bool)
    return {
        "collided_cars": int(len(c["row"])),
        "in_junction": int(inside.sum()),
        "by_kind": {name: {"cars": int(np.sum(c["kind"] == k)),
                           "in_junction": int(np.sum((c["kind"] == k) & inside))}
                    for k, name in enumerate(CLASSES)},
    }


def wreck_collision_room(table: dict[str, np.ndarray], a_max: float, car_length: float) -> dict:
    """Pile-ups: for each car that hit a wreck, whether on the wreck's crash decision it had room
    to stop: its straight-line gap to the wreck (centre distance - ``car_length``, m) at least its
    stopping distance ``v^2 / (2 a_max)`` (v in m/s, a_max in m/s^2). A straight line is never
    longer than the path, so ``room_to_stop`` counts pile-ups that braking alone could have
    avoided, at least. For the cars with and without room: median gap and speed then, and the
    median number of decisions from the wreck's crash to the car's."""
    c = collision_classes(table)
    wreck_rows = c["row"][c["kind"] == CLASSES.index("wreck")]
    ep, car, dec = (table[k].astype(np.int64) for k in ("episode", "car", "decision"))
    find = row_lookup(table)
    crash = {(int(ep[r]), int(car[r])): int(r) for r in c["row"].tolist()}
    gaps, speeds, delays = [], [], []
    for r in wreck_rows.tolist():
        wreck = crash.get((int(ep[r]), int(table["collision_partner"][r])))
        if wreck is None:
            raise ValueError(f"row {r}: car {car[r]} hit wreck {table['collision_partner'][r]}, "
                             "which has no crash row in that episode")
        at = int(find(ep[r], car[r], dec[wreck]))
        if at < 0:
            raise ValueError(f"row {r}: car {car[r]} has no row on decision {dec[wreck]}, when wreck "
                             f"{table['collision_partner'][r]} halted")
        gaps.append(math.hypot(table["x"][at] - table["x"][wreck], table["y"][at] - table["y"][wreck]) - car_length)
        speeds.append(float(table["speed"][at]))
        delays.append(int(dec[r] - dec[wreck]))
    gap, speed, delay = np.array(gaps), np.array(speeds), np.array(delays, dtype=np.int64)
    room = gap >= stopping_distance(speed, a_max)

    def medians(m: np.ndarray) -> dict:
        if not m.any():
            return {"cars": 0, "gap_median": float("nan"), "speed_median": float("nan"),
                    "decisions_to_hit_median": float("nan")}
        return {"cars": int(m.sum()), "gap_median": float(np.median(gap[m])),
                "speed_median": float(np.median(speed[m])), "decisions_to_hit_median": float(np.median(delay[m]))}

    return {
        "cars": int(len(delay)),
        "room_to_stop": int(room.sum()),
        "decisions_after_wreck_median": float(np.median(delay)) if len(delay) else float("nan"),
        "decisions_after_wreck_max": int(delay.max(initial=0)),
        "with_room": medians(room),
        "without_room": medians(~room),
    }
