"""The env core: one decision of one or several instances of a scenario, as arrays.

:meth:`DrivingEnv.step <box2d_driving.envs.base.DrivingEnv.step>` steps its one instance through
:func:`step_instances`, and so does training's vector env with every instance of its process at
once (``training/ppo/vec_env.py``). What each instance owns is done per instance: its Box2D world
(:meth:`DrivingWorld.advance <box2d_driving.physics.world.DrivingWorld.advance>`), its random
generator (LiDAR dropout), its lights and the scenario's hooks. Everything that is a formula over
cars (acceleration levels, reward terms, sat-nav columns, LiDAR encoding, the numbers in the infos)
runs once over the cars of all instances together, gathered by concatenation: the same
element-wise operations on the same values, so a car's numbers do not depend on which other
instances were stepped with it (``tests/test_env_core.py`` checks this bit for bit), while the
numpy call overhead is paid once per decision instead of once per instance.

Only the PettingZoo boundary (:class:`~box2d_driving.envs.base.DrivingEnv`) builds per-agent dicts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from box2d_driving.envs import kernels
from box2d_driving.envs.reward import TERMS, reward_terms
from box2d_driving.physics.world import COLLIDED
from box2d_driving.road.geometry import wrap_angle
from box2d_driving.road.lights import NO_LIGHT, light_values, visible_from_points, visible_lights
from box2d_driving.sensors import lidar, readout

# instances of box2d_driving.envs.base.DrivingEnv (not imported: base imports this module)
Envs = Sequence[Any]


@dataclass
class Decision:
    """One decision of one instance, as arrays over the cars that acted in it.

    Attributes:
        cars: ``(n,)`` indices of the cars that acted (the live agents before the step), ascending.
        observations: ``(n, D)`` float32, each car's observation after the decision.
        rewards: ``(n,)`` the sum of the reward terms.
        terms: each reward term, ``(n,)``: :data:`box2d_driving.envs.reward.TERMS`, then the
            scenario's ``reward_extras``.
        terminated: ``(n,)`` the car reached its goal or crashed in this decision.
        truncated: the horizon ended the episode with this decision (for every car not terminated).
        infos: one dict per car (the env's documented keys, ``reward_terms`` last).
    """

    cars: np.ndarray
    observations: np.ndarray
    rewards: np.ndarray
    terms: dict[str, np.ndarray]
    terminated: np.ndarray
    truncated: bool
    infos: list[dict[str, Any]]


def _cat(parts: Sequence[np.ndarray]) -> np.ndarray:
    """The parts end to end (the part itself when there is one: callers never write into it)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _flat(envs: Envs, cars: Sequence[np.ndarray]) -> np.ndarray:
    """Indices of ``cars`` (per instance) into arrays gathered over ``envs`` (``num_cars`` each)."""
    if len(envs) == 1:
        return cars[0]
    n = envs[0].config.num_cars
    return np.concatenate([c + k * n for k, c in enumerate(cars)])


def step_instances(envs: Envs, actions: Sequence[np.ndarray]) -> list[Decision]:
    """One decision of each instance in ``envs`` (one scenario class and config, all reset and
    with live agents); ``actions[k]`` holds the raw integer actions of ``envs[k]``'s live cars in
    agent order, already checked. Updates every instance's state and live agents."""
    first = envs[0]
    cfg = first.config
    n = cfg.num_cars
    acting = [env._acting for env in envs]
    flat = _flat(envs, acting)
    raw = _cat(actions)
    levels = first._levels
    prev = _cat([env._prev_level for env in envs])
    level, bits, accel = prev.copy(), np.zeros(len(prev)), np.zeros(len(prev))
    kernels.split_actions(flat, raw, levels, _cat([env.world.ratings for env in envs]), cfg.communication,
                          level, bits, accel)

    events = []
    for k, env in enumerate(envs):
        events.append(env.world.advance(accel[k * n:(k + 1) * n]))
        env.decision += 1
        env._bits = bits[k * n:(k + 1) * n]

    arrived = _cat([e.arrived for e in events])[flat]
    collided = _cat([e.collided for e in events])[flat]
    remaining = _cat([env.world.s_goal for env in envs]) - _cat([env.world.s for env in envs])
    if cfg.arrived_cars_stay:  # past its goal a car has nothing left to drive
        remaining = np.maximum(remaining, 0.0)
    decision = np.repeat(np.array([env.decision for env in envs], dtype=np.int64),
                         [len(c) for c in acting])
    terms = reward_terms(
        arrived=arrived, collided=collided, accel_level=level[flat], prev_accel_level=prev[flat],
        accel_range=first._accel_range, remaining=remaining[flat],
        initial=_cat([env._initial for env in envs])[flat], decision=decision, horizon=cfg.horizon,
        goal_reward=cfg.goal_reward, collision_reward=cfg.collision_reward,
    )
    for k, env in enumerate(envs):
        env._prev_level = level[k * n:(k + 1) * n]
    if cfg.smoothness == "squared":
        terms["smoothness"] = -((level[flat] - prev[flat]) / first._accel_range) ** 2 / cfg.horizon
    if cfg.arrived_cars_stay:  # after arriving: stop there (the progress term becomes a speed penalty)
        waiting = _cat([env._arrived_before for env in envs])[flat]
        if waiting.any():
            speed = np.abs(_cat([env.world.speed for env in envs])[flat])
            v_lim = _cat([env.world.v_lim for env in envs])[flat]
            terms["progress"] = np.where(waiting, -(speed / v_lim) / cfg.horizon, terms["progress"])
        for env in envs:
            env._arrived_before = env.world.has_arrived.copy()
    if first.reward_extras:  # the scenario's own terms, after the shipped ones
        extra = np.concatenate([np.asarray(env.reward_extra_values(c), dtype=np.float64).reshape(len(c), -1)
                                for env, c in zip(envs, acting)])
        if extra.shape[1] != len(first.reward_extras):
            raise ValueError(f"{type(first).__name__}.reward_extra_values gave {extra.shape[1]} terms per car, "
                             f"reward_extras names {len(first.reward_extras)}")
        terms.update(zip(first.reward_extras, extra.T))
    names = TERMS + tuple(first.reward_extras)
    total = sum((terms[t] for t in names), np.zeros(len(flat)))  # in order: the same sums as ever

    lidar_frame, satnav_frame = frames(envs, acting, senders=acting)
    infos = car_infos(envs, acting)
    for info, values in zip(infos, zip(*[terms[t].tolist() for t in names])):
        info["reward_terms"] = dict(zip(names, values))
    done = collided if cfg.arrived_cars_stay else arrived | collided

    out, start = [], 0
    for env, cars in zip(envs, acting):
        rows = slice(start, start + len(cars))
        start += len(cars)
        env.history.push(cars, lidar_frame[rows], satnav_frame[rows])
        truncated = env.decision >= cfg.horizon
        gone = done[rows]
        out.append(Decision(cars=cars, observations=env.history.observations(cars), rewards=total[rows],
                            terms={t: terms[t][rows] for t in names}, terminated=gone,
                            truncated=truncated, infos=infos[rows]))
        env._acting = cars[:0] if truncated else cars[~gone]
        env.agents = [env.possible_agents[i] for i in env._acting.tolist()]
    return out


def frames(envs: Envs, cars: Sequence[np.ndarray],
           senders: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """LiDAR and sat-nav frames of ``cars[k]`` of each instance ``envs[k]`` at its current state,
    rows in that order; ``senders[k]`` are the cars whose bits were sent in the last decision."""
    first = envs[0]
    cfg = first.config
    flat = _flat(envs, cars)
    distances = lidar_distances(envs, cars)
    draws = [readout.dropout_draws(env.np_random, len(c), cfg.n_rays, cfg.lidar_noise, cfg.lidar_dropout)
             for env, c in zip(envs, cars)]
    dropped = readout.dropout_from_draws(_cat(draws), len(flat), cfg.n_rays, cfg.lidar_noise, cfg.lidar_dropout)
    start = 0
    for env, c in zip(envs, cars):
        if env.render_mode is not None:  # kept for drawing the rays
            rows = slice(start, start + len(c))
            if env._last_rays is None or env.decision == 0:
                env._last_rays = np.full((cfg.num_cars, cfg.n_rays), np.inf)
                env._last_dropped = np.zeros((cfg.num_cars, cfg.n_rays), dtype=bool)
            env._last_rays[c] = distances[rows]
            env._last_dropped[c] = dropped[rows]
        start += len(c)
    lidar_frame = readout.encode(distances, cfg.lidar_range, cfg.lidar_encoding, dropped)

    worlds = [env.world for env in envs]
    positions = _cat([w.positions for w in worlds])
    head = _cat([w.headings for w in worlds])[flat]
    _update_lights_seen(envs, cars, flat, positions[flat], head)
    n_extra = len(first.satnav_extras)
    satnav = np.empty((len(flat), 4 + n_extra + int(cfg.communication)), dtype=np.float32)
    to_goal, remaining = np.empty((2, len(flat))), np.empty(len(flat))
    kernels.satnav_columns(flat, positions, _cat([w.s_goal for w in worlds]),
                           _cat([w.s for w in worlds]), _cat([env._goals for env in envs]),
                           _cat([w.speed for w in worlds]), _cat([w.v_lim for w in worlds]),
                           _cat([env._seen for env in envs]), satnav, to_goal, remaining)
    # numpy's arctan2, as before (its vectorised and the C library's scalar versions may round
    # differently)
    heading_error = wrap_angle(np.arctan2(to_goal[1], to_goal[0]) - head)
    past = remaining <= 0
    paper_readings = cfg.goal_distance == "straight" or cfg.arrived_heading_error == "minus_heading"
    # the paper's code moves an arrived car's goal onto it for good: its readings stay an arrived
    # car's even after it backs out past its goal (ours read the track again); only those
    # readings need it, so other worlds skip the gather
    arrived = past | _cat([w.has_arrived for w in worlds])[flat] if paper_readings else past
    if cfg.goal_distance == "straight":  # the paper's code: to the goal point, 1 once arrived
        satnav[:, 3] = np.where(arrived, 1.0, 1.0 / np.maximum(np.hypot(to_goal[0], to_goal[1]), 1.0))
    # past its goal: 0, or the paper's code's reading with the goal moved onto the car
    if cfg.arrived_heading_error == "minus_heading":
        turned = _cat([env._turned for env in envs])[flat]
        heading_error[arrived] = arrived_heading_reading(head[arrived], turned[arrived])
    else:
        heading_error[past] = 0.0
    satnav[:, 2] = heading_error
    if n_extra:
        satnav[:, 4:4 + n_extra] = _cat([env.satnav_extra_values()[c] for env, c in zip(envs, cars)])
    if cfg.communication:
        for env, c, s in zip(envs, cars, senders):
            env._received[c] = env._receive(c, s) if cfg.messages_heard else 0.0
        satnav[:, -1] = _cat([env._received for env in envs])[flat]
    return lidar_frame, satnav


# a heading this close to +-pi counts as due west (rad): a straight track's heading is exact, a
# turned car's is Box2D's float32 angle after the turn's rotations (measured 1.8e-6 off)
DUE_WEST_TOLERANCE = 1e-4


def arrived_heading_reading(heading: np.ndarray, turned: np.ndarray | None = None) -> np.ndarray:
    """The paper's code's heading error of an arrived car (its goal moved onto it): minus its
    ``heading`` (rad), wrapped to ``[-pi, pi)``. That code holds a car heading due west as +pi
    (float32), so it reads -pi; ours may hold the same car just above -pi, which negated would
    land on the other side of the cut (+pi): a heading within :data:`DUE_WEST_TOLERANCE` of +-pi
    is taken as +pi first. A car whose track ``turned`` (its start heading plus a right angle,
    in float32, just past +-pi) reads +pi there instead, as the paper's code's turning world
    records it. Only the sign at the cut changes, but a policy reads -pi and +pi as far apart
    as two inputs can be."""
    heading = np.asarray(heading, dtype=float)
    west = np.abs(np.abs(heading) - np.pi) < DUE_WEST_TOLERANCE
    reading = wrap_angle(-np.where(west, np.pi, heading))
    if turned is not None:
        reading = np.where(west & np.asarray(turned, dtype=bool), np.pi, reading)
    return reading


def _update_lights_seen(envs: Envs, cars: Sequence[np.ndarray], flat: np.ndarray, pos: np.ndarray,
                        head: np.ndarray) -> None:
    """Each instance's ``_seen`` for its ``cars``: the light each sees (``NO_LIGHT`` for none) at
    positions ``pos`` and headings ``head`` (rows of ``flat``)."""
    cfg = envs[0].config
    from_axis = envs[0].sees_light_from_axis
    if len(envs) == 1 and not from_axis:  # one junction: its own rule, in plain floats (fastest for a few cars)
        env = envs[0]
        if env.layout.lights is not None:
            env._seen[flat] = env.layout.lights.seen(env.time, env._light_index[flat], pos, head,
                                                     cfg.light_view_distance)
    elif any(env.layout.lights is not None for env in envs):  # the same rule over every instance's cars
        stop = _cat([env._stop_point for env in envs])[flat]
        direction = _cat([env._stop_direction for env in envs])[flat]
        if from_axis:  # the paper's code: a straight line to its arm's axis at the junction
            visible = visible_from_points(stop, _cat([env._view_point for env in envs])[flat], direction, pos,
                                          cfg.light_view_distance)
        else:
            visible = visible_lights(stop, direction, pos, head, cfg.light_view_distance)
        seen = np.full(len(flat), NO_LIGHT)
        if visible.any():  # the lights' values only for the cars that see one (few, most decisions)
            lights = [env.layout.lights for env in envs]
            none = (0.0, 0.0, 0.0)  # an instance without lights: none of its cars sees one
            params = np.array([(env.time,) + ((x.half_period, x.yellow, x.offset) if x is not None else none)
                               for env, x in zip(envs, lights)])
            scene = np.repeat(np.arange(len(envs)), [len(c) for c in cars])[visible]
            seen[visible] = light_values(params[scene, 0], _cat([env._light_group for env in envs])[flat[visible]],
                                         params[scene, 1], params[scene, 2], params[scene, 3])
        start = 0
        for env, c in zip(envs, cars):
            if env.layout.lights is not None:
                env._seen[c] = seen[start:start + len(c)]
            start += len(c)


def lidar_distances(envs: Envs, cars: Sequence[np.ndarray]) -> np.ndarray:
    """Noise-free LiDAR distances (m, ``inf``: no return) of ``cars[k]`` of each instance
    ``envs[k]``, rows in that order: every scene in one compiled call (``numba``), or ray by ray
    through each instance's Box2D world (``box2d``, the reference)."""
    first = envs[0]
    cfg = first.config
    worlds = [env.world for env in envs]
    if first._backend == "box2d":
        return _cat([lidar.cast_rays_box2d(w.world, [w.car_bodies[i] for i in c], w.positions[c], w.headings[c],
                                           cfg.n_rays, cfg.lidar_range, cfg.lidar_sees_pedestrians,
                                           cfg.lidar_min_range)
                     for w, c in zip(worlds, cars)])
    if cfg.lidar_sees_pedestrians:
        peds = [w.ped_sizes for w in worlds]
        ped_positions, ped_sizes = _cat([w.ped_positions for w in worlds]), _cat(peds)
    else:
        peds = [w.ped_sizes[:0] for w in worlds]
        ped_positions, ped_sizes = np.zeros((0, 2)), np.zeros(0)
    edges = [w.edge_segments.reshape(-1, 4) for w in worlds]
    # car j of these instances uses slot j: the same instances in the same order every decision
    # (training's vector env) reuse their cars' directions; any other order only recomputes them
    first._ray_directions = lidar.RayDirections.sized(first._ray_directions, len(envs) * cfg.num_cars, cfg.n_rays)
    return lidar.cast_rays_scenes(
        _cat([w.positions for w in worlds]), _cat([w.headings for w in worlds]), _cat([w.present for w in worlds]),
        cfg.num_cars, _flat(envs, cars), cfg.car_length, cfg.car_width, ped_positions, ped_sizes,
        np.array([len(p) for p in peds], dtype=np.int64), _cat(edges),
        np.array([len(e) for e in edges], dtype=np.int64), cfg.n_rays, cfg.lidar_range, first._ray_directions,
        cfg.lidar_min_range)


# every car's ``infos[agent]`` (units and meaning; the scenario pages print this table)
INFO_FIELDS = {
    "position": "(x, y) of the car's centre (m)",
    "heading": "heading (rad, counter-clockwise from +x)",
    "speed": "speed along the heading (m/s; negative only where the world lets cars reverse)",
    "acceleration": "acceleration applied this decision (m/s²)",
    "light": "the light value the car sees on its approach: 0.0 and 1.0 the two phases (green and red as "
             "drawn; which one a policy learns to stop on is its `stop_value`), 0.5 yellow, 0.75 no light "
             "in view",
    "in_junction": "whether the car's centre is inside the junction area",
    "lane_offset": "signed offset from its lane's axis, normalised by W/2, + = right of the direction of "
                   "travel (None without a road axis)",
    "stop_line_distance": "distance before its stop line (m; None without a light on its approach)",
    "distance_to_goal": "distance left along its path (m)",
    "arrived": "whether the car has reached its goal (this decision or before)",
    "collided": "whether the car has collided",
    "collided_with": "what it hit: `car`, `edge`, `pedestrian` (None before any collision)",
    "collision_partner": "the index of the car it hit (None otherwise)",
    "partner_halted": "whether that car had halted when it was hit",
    "rating": "the car's acceleration rating (1.0 where the scenario has none)",
    "decision": "the decision number in the episode (0 at reset)",
    "approach": "the arm (or lane) the car came from",
    "reward_terms": "the decision's reward term by term (absent at reset)",
    "bit_sent": "with `communication=True`: the bit the car sent",
    "bit_received": "with `communication=True`: the bit it heard",
}


def car_infos(envs: Envs, cars: Sequence[np.ndarray]) -> list[dict[str, Any]]:
    """One info dict per car in ``cars[k]`` of each instance ``envs[k]`` (the keys the envs
    document), rows in that order, with each scenario's own facts
    (:meth:`~box2d_driving.envs.base.DrivingEnv.scenario_info`) added."""
    flat = _flat(envs, cars)
    worlds = [env.world for env in envs]
    positions = _cat([w.positions for w in worlds])
    pos = positions[flat]
    offset, stop = np.empty(len(flat)), np.empty(len(flat))
    kernels.axis_offsets_and_stop_distances(
        flat, positions, _cat([env._lane_origin for env in envs]), _cat([env._lane_right for env in envs]),
        _cat([env._lane_half_width for env in envs]), _cat([env._stop_point for env in envs]),
        _cat([env._stop_direction for env in envs]), offset, stop)
    in_junction = _cat([env.layout.in_junction(w.positions[c]) for env, w, c in zip(envs, worlds, cars)])

    # per-car dicts from whole-array columns: each column read once as plain values (the same
    # numbers as indexing it per car), then one dict per car in the documented key order
    def column(values: list[np.ndarray]) -> list:
        gathered = _cat(values)
        # every car acted (flat is every row, in order): no need to pick rows
        return (gathered if len(flat) == len(gathered) else gathered[flat]).tolist()

    heading, speed = column([w.headings for w in worlds]), column([w.speed for w in worlds])
    accel, seen = column([w.accel for w in worlds]), column([env._seen for env in envs])
    togo = column([w.s_goal - w.s for w in worlds])
    status = column([w.status for w in worlds])
    has_arrived = column([w.has_arrived for w in worlds])
    partner, halted = column([w.collision_partner for w in worlds]), column([w.partner_halted for w in worlds])
    rating = column([w.ratings for w in worlds])
    offsets = [None if v != v else v for v in offset.tolist()]  # None: no lane axis (NaN)
    stops = [None if v != v else v for v in stop.tolist()]  # None: no light on its approach
    in_junction = in_junction.tolist()
    idx, decision, approach, collided_with = [], [], [], []
    for env, w, c in zip(envs, worlds, cars):
        ci = c.tolist()
        idx += ci
        decision += [env.decision] * len(ci)
        approach += [env._approach[i] for i in ci]
        collided_with += [w.collided_with[i] for i in ci]
    infos = [{"position": p, "heading": heading[k], "speed": speed[k], "acceleration": accel[k],
              "light": seen[k], "in_junction": in_junction[k], "lane_offset": offsets[k],
              "stop_line_distance": stops[k], "distance_to_goal": togo[k],
              "arrived": has_arrived[k], "collided": status[k] == COLLIDED,
              "collided_with": collided_with[k], "collision_partner": partner[k],
              "partner_halted": halted[k], "rating": rating[k], "decision": decision[k],
              "approach": approach[k]}
             for k, p in enumerate(pos)]
    if envs[0].config.communication:
        bits = column([env._bits for env in envs])
        heard = column([env._received for env in envs])
        for info, b, h in zip(infos, bits, heard):
            info["bit_sent"], info["bit_received"] = int(b), int(h)
    start = 0
    for env, c in zip(envs, cars):
        if env.adds_scenario_info:  # a scenario's own facts
            for info, extra in zip(infos[start:start + len(c)], env.scenario_info(c)):
                info.update(extra)
        start += len(c)
    return infos
