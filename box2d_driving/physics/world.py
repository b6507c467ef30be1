"""The Box2D world of one episode: car and pedestrian bodies, velocity control, contacts.

Cars follow their paths by velocity control: every physics step, Box2D is given the velocity that
carries the body along the exactly integrated path motion, and Box2D integrates it, so contacts and
ray casts see the real swept motion. Bodies are Box2D sensors: a contact is an event, never an
impulse, so a collided car halts exactly where it touched. Contacts are evaluated after every
physics step (a zero-length ``Step`` updates them at the new poses), so an overlap is recorded on
the step that created it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from box2d_driving.physics.box2d_py import (b2_dynamicBody, b2BodyDef, b2EdgeShape, b2FixtureDef, b2PolygonShape,
                                             b2World)

from box2d_driving.config import DrivingConfig
from box2d_driving.physics.contacts import (
    CAR, CAT_CAR, CAT_EDGE, CAT_PEDESTRIAN, EDGE_TAG, PEDESTRIAN, ContactRecorder,
)
from box2d_driving.physics.kinematics import chord_velocities, free_profile, longitudinal_profile, path_poses
from box2d_driving.road.geometry import pack_paths, wrap_angle
from box2d_driving.road.layout import Layout

ACTIVE = 0
ARRIVED = 1
COLLIDED = 2

# Box2D solver iterations: bodies are sensors, so there are no constraints to solve.
_VELOCITY_ITERATIONS = 1
_POSITION_ITERATIONS = 1


@dataclass
class DecisionEvents:
    """What happened to each car during one decision.

    Attributes:
        arrived: ``(N,)`` reached its goal during this decision.
        collided: ``(N,)`` had its first collision during this decision.
        collided_with: per car, ``"car"``, ``"edge"``, ``"pedestrian"`` or None.
        partner: ``(N,)`` index of the car hit (-1 if none or not a car).
        partner_halted: ``(N,)`` the car hit had already halted (a wreck) before the contact.
        substep: ``(N,)`` physics step (1-based) of the event, 0 if none.
    """

    arrived: np.ndarray
    collided: np.ndarray
    collided_with: list
    partner: np.ndarray
    partner_halted: np.ndarray
    substep: np.ndarray

    @staticmethod
    def none(n: int) -> "DecisionEvents":
        """No event for any of ``n`` cars."""
        return DecisionEvents(
            arrived=np.zeros(n, dtype=bool), collided=np.zeros(n, dtype=bool),
            collided_with=[None] * n, partner=np.full(n, -1, dtype=np.int64),
            partner_halted=np.zeros(n, dtype=bool), substep=np.zeros(n, dtype=np.int64),
        )


class DrivingWorld:
    """Owns the ``b2World`` of one episode and the cars' longitudinal state."""

    def __init__(self, config: DrivingConfig) -> None:
        self.config = config
        self.contacts = ContactRecorder()
        self.world: b2World | None = None
        self.layout: Layout | None = None
        self.car_bodies: list = []
        self.ped_bodies: list = []
        self._edge_body = None  # the static body holding the road edges' fixtures
        self._fixtures: list = []  # every fixture of this world (all carry userData, which release() drops)
        # One shape of each kind, reused: a fixture copies its shape, but pybox2d never frees a
        # shape object once it has been handed to a fixture definition (64 bytes per fixture,
        # about 50 MiB per 1,000 resets of a real junction if a new one were made each time).
        self._edge_shape = b2EdgeShape(vertices=[(0.0, 0.0), (1.0, 0.0)])
        self._box_shape = b2PolygonShape(box=(0.5, 0.5))
        # Likewise one definition of each fixture and of a moving body, reused: a definition
        # points at its shape (edited in place before each fixture) and Box2D copies it into the
        # fixture or body it creates; building them from keywords each time was a third of a reset.
        self._edge_def = b2FixtureDef(shape=self._edge_shape, isSensor=True,
                                      categoryBits=CAT_EDGE, maskBits=CAT_CAR)
        self._car_def = b2FixtureDef(shape=self._box_shape, density=1.0, isSensor=True, categoryBits=CAT_CAR,
                                     maskBits=CAT_CAR | CAT_EDGE | CAT_PEDESTRIAN)
        self._ped_def = b2FixtureDef(shape=self._box_shape, density=1.0, isSensor=True,
                                     categoryBits=CAT_PEDESTRIAN, maskBits=CAT_CAR)
        self._body_def = b2BodyDef(type=b2_dynamicBody)

    # -- building ------------------------------------------------------------------------------
    def reset(self, layout: Layout) -> None:
        """Build a fresh ``b2World`` for ``layout``: one static body with a fixture per road edge,
        a box body per car at the start of its path (standing, arc length 0) and per pedestrian
        (moving at its velocity); the previous episode's world is released first."""
        cfg = self.config
        self.layout = layout
        self.release()
        self.world = world = b2World(gravity=(0, 0), doSleep=False, contactListener=self.contacts)
        n = len(layout.cars)
        self.n_cars = n

        # Every edge fixture shares one tag (nothing needs an edge's index); plain-float pairs
        # set the same vertices as numpy rows would, without a tuple per row
        self.edge_segments = np.asarray(layout.edges, dtype=float).reshape(-1, 2, 2)
        self._edge_body = edge_body = world.CreateStaticBody()
        for a, b in self.edge_segments.tolist():
            self._edge_shape.vertices = [a, b]
            fx = edge_body.CreateFixture(self._edge_def)
            fx.userData = EDGE_TAG
            self._fixtures.append(fx)

        paths = [c.path for c in layout.cars]
        self.path_points, self.path_cumlen, self.path_counts = pack_paths(paths)
        self.s_end = np.array([p.length for p in paths], dtype=float)
        # where each car counts as arrived (its path's end unless the scenario says otherwise)
        self.s_goal = np.array([p.length if c.goal_s is None else c.goal_s for p, c in zip(paths, layout.cars)],
                               dtype=float)
        self.ratings = np.array([c.rating for c in layout.cars], dtype=float)
        self.v_lim = cfg.v_lim * self.ratings
        self.v_min = -self.v_lim if cfg.reverse else np.zeros(n)
        self.s = np.array([c.start_s for c in layout.cars], dtype=float)
        self.has_arrived = np.zeros(n, dtype=bool)
        # cars that reverse or stay after arriving move by the general profile (free_profile)
        self._free = cfg.reverse or cfg.arrived_cars_stay
        self.speed = np.zeros(n)
        self.accel = np.zeros(n)
        self.status = np.full(n, ACTIVE, dtype=np.int64)
        self.collided_with: list = [None] * n
        self.collision_partner = np.full(n, -1, dtype=np.int64)
        self.partner_halted = np.zeros(n, dtype=bool)

        self._box_shape.SetAsBox(cfg.car_length / 2, cfg.car_width / 2)
        bd = self._body_def
        self.car_bodies = []
        for i, spawn in enumerate(layout.cars):
            (x, y), heading = spawn.path.start_pose() if spawn.start_s == 0.0 else spawn.path.pose(spawn.start_s)
            bd.position, bd.angle = (float(x), float(y)), float(heading)
            body = self.world.CreateBody(bd)
            fx = body.CreateFixture(self._car_def)
            fx.userData = (CAR, i)
            self.car_bodies.append(body)
            self._fixtures.append(fx)
        self._angular = [0.0] * n
        self._turns = (self.path_counts > 2).tolist()  # paths of more than one segment
        self._standing = [True] * n  # whether a car's body was last given zero linear velocity

        self.ped_bodies = []
        self.ped_bounds = np.array([p.y_bounds for p in layout.pedestrians], dtype=float).reshape(-1, 2)
        self.ped_sizes = np.array([p.size for p in layout.pedestrians], dtype=float)
        self.ped_velocity = np.array([p.velocity for p in layout.pedestrians], dtype=float).reshape(-1, 2)
        self.ped_turn_back = [p.turn_back for p in layout.pedestrians]
        for k, ped in enumerate(layout.pedestrians):
            bd.position, bd.angle = tuple(map(float, ped.position)), 0.0
            body = self.world.CreateBody(bd)
            self._box_shape.SetAsBox(ped.size / 2, ped.size / 2)
            fx = body.CreateFixture(self._ped_def)
            fx.userData = (PEDESTRIAN, k)
            body.linearVelocity = tuple(map(float, ped.velocity))
            self.ped_bodies.append(body)
            self._fixtures.append(fx)

        # Evaluate contacts at the spawn poses (spawns never overlap, so this records nothing).
        self.world.Step(0.0, _VELOCITY_ITERATIONS, _POSITION_ITERATIONS)
        self.contacts.drain()
        self.read_poses()

    def release(self) -> None:
        """Free the previous episode's world. pybox2d keeps a reference to each fixture's
        ``userData`` until that fixture is destroyed, and a world whose bodies are still alive is
        never freed: without this every reset leaked its world (about 50 MiB per 1,000 resets of a
        real junction with its hundreds of edge fixtures)."""
        self.contacts.drain()
        if self.world is None:
            return
        # the bodies and fixtures this world was given, from our own lists: walking Box2D's
        # linked lists (world.bodies, body.fixtures) costs pybox2d a Python loop, a third of a
        # real junction's reset with its hundreds of edge fixtures
        for fixture in self._fixtures:
            fixture.ClearUserData()  # drops pybox2d's reference to the (kind, index) tuple
        for body in (*self.car_bodies, *self.ped_bodies, self._edge_body):
            if body is not None:
                self.world.DestroyBody(body)
        self.world.contactListener = None
        self.world = None
        self.car_bodies, self.ped_bodies, self._edge_body, self._fixtures = [], [], None, []

    # -- stepping -----------------------------------------------------------------------------
    def advance(self, accel: np.ndarray) -> DecisionEvents:
        """Hold accelerations ``accel`` (m/s^2, per car) for one decision: the motion of every
        moving car over the decision's physics steps is integrated exactly first
        (:meth:`_plan_motion`), then Box2D runs the steps with those velocities, and a car halts
        on the step of its first contact or stops on the step it reaches its goal."""
        k_steps, dt = self.config.substeps, self.config.dt
        world = self.world
        if world is None:
            raise RuntimeError("advance() before reset(): no world to step")
        moving = self.status == ACTIVE
        self.accel = np.where(moving, accel, 0.0)
        s_out, v_out, arrive, heading, velocity, always, never = self._plan_motion(moving)
        rows = np.flatnonzero(moving)
        live = rows.tolist()
        # only a path of more than one segment turns: a one-segment path's angular velocity is
        # exactly 0 at every step, the value its body has, so it is never written
        turning = [i for i in live if self._turns[i]]
        if turning:
            angular = dict(zip(live, (wrap_angle(heading[rows, 1:] - heading[rows, :-1]) / dt).tolist()))
        arriving: dict[int, list[int]] = {}  # physics step (1-based) -> cars reaching their goal
        for i in rows[arrive[rows] > 0].tolist():
            arriving.setdefault(int(arrive[i]), []).append(i)

        events = DecisionEvents.none(self.n_cars)
        bodies, standing, spin = self.car_bodies, self._standing, self._angular
        # A car standing still (waiting at a red light) keeps the zero velocity it has: no gravity
        # or damping acts on these bodies, so Box2D leaves it exactly as set, and a zero velocity
        # is written only when a car comes to a stop. Cars moving at every step get theirs written
        # without that test (``driving``), cars standing throughout are left alone; the others
        # (``stopping``) test each step.
        driving, stopping = [], []
        for i, v, go, stay in zip(live, velocity.tolist(), always.tolist(), never.tolist()):
            if go:
                driving.append((i, bodies[i], v))
                standing[i] = False  # as after its first write, which comes before any test of it
            elif not (stay and standing[i]):
                stopping.append((i, bodies[i], v))
        for k in range(k_steps):
            for _, body, v in driving:
                body.linearVelocity = v[k]
            for i, body, v in stopping:
                if v[k][0] or v[k][1]:
                    body.linearVelocity = v[k]
                    standing[i] = False
                elif not standing[i]:
                    body.linearVelocity = v[k]
                    standing[i] = True
            for i in turning:
                w = angular[i][k]
                if w != spin[i]:
                    bodies[i].angularVelocity = w
                    spin[i] = w
            world.Step(dt, _VELOCITY_ITERATIONS, _POSITION_ITERATIONS)
            world.Step(0.0, _VELOCITY_ITERATIONS, _POSITION_ITERATIONS)
            # a car leaves the step loop's lists when it halts (first contact) or arrives
            done_now = []
            if self.contacts.events:
                for i in self._apply_contacts(self.contacts.drain(), events, k + 1):
                    self.s[i] = s_out[i, k + 1]
                    if i in live:
                        done_now.append(i)
                        live.remove(i)
            for i in arriving.get(k + 1, ()):
                if i in live and self.config.arrived_cars_stay:  # it counts as arrived and drives on
                    self.has_arrived[i] = events.arrived[i] = True
                    events.substep[i] = k + 1
                elif i in live:  # not halted by a contact earlier in this decision
                    done_now.append(i)
                    live.remove(i)
                    self._arrive(i, events, k + 1, v_out[i, k + 1])
            for i in done_now:
                driving, stopping = _without(driving, i), _without(stopping, i)
                if i in turning:
                    turning.remove(i)
        for i in live:
            self.s[i] = s_out[i, k_steps]
            self.speed[i] = v_out[i, k_steps]
        self._turn_pedestrians()
        self.read_poses(rows)
        return events

    def _plan_motion(self, moving: np.ndarray):
        """The decision's motion of every car, integrated exactly by the compiled kernels.

        Returns arc length ``s_out`` and speed ``v_out`` ``(N, K + 1)`` at each physics step's end
        (column 0: now), ``arrive`` ``(N,)`` the 1-based step a car reaches its goal (0: not in
        this decision), ``heading`` ``(N, K + 1)``, and for the moving cars (in index order)
        ``velocity`` ``(M, K, 2)`` (m/s) to give Box2D at each step, with ``always`` / ``never``
        (``(M,)``) whether that velocity is non-zero at every step / at none.
        """
        cfg = self.config
        n, k_steps, dt = self.n_cars, cfg.substeps, cfg.dt
        s_out = np.empty((n, k_steps + 1))
        v_out = np.empty((n, k_steps + 1))
        arrive = np.zeros(n, dtype=np.int64)
        euler = cfg.integration == "euler"
        if self._free:
            free_profile(self.s, self.speed, self.accel, self.v_min, self.v_lim, self.s_goal, self.s_end,
                         self.has_arrived, moving, dt, k_steps, s_out, v_out, arrive, euler)
        else:
            longitudinal_profile(self.s, self.speed, self.accel, self.v_lim, self.s_end, moving,
                                 dt, k_steps, s_out, v_out, arrive, euler)
        xy = np.empty((n, k_steps + 1, 2))
        heading = np.empty((n, k_steps + 1))
        path_poses(self.path_points, self.path_cumlen, self.path_counts, s_out, xy, heading)
        rows = np.flatnonzero(moving)
        velocity = np.empty((len(rows), k_steps, 2))
        always, never = np.empty(len(rows), dtype=bool), np.empty(len(rows), dtype=bool)
        chord_velocities(xy, rows, dt, velocity, always, never)
        return s_out, v_out, arrive, heading, velocity, always, never

    def _arrive(self, i: int, events: DecisionEvents, substep: int, speed: float) -> None:
        """Car ``i`` reached its goal on physics step ``substep`` at ``speed`` (m/s): it stops
        there and its body leaves the world."""
        self.status[i] = ARRIVED
        self.has_arrived[i] = events.arrived[i] = True
        events.substep[i] = substep
        self.s[i] = self.s_goal[i]
        self.speed[i] = speed
        body = self.car_bodies[i]
        body.linearVelocity = (0.0, 0.0)
        self._standing[i] = True
        body.angularVelocity = 0.0
        body.active = False

    def _apply_contacts(self, contacts, events: DecisionEvents, substep: int) -> list[int]:
        """Mark first collisions; returns the cars that collided now."""
        hit: list[int] = []
        halted = self.status == COLLIDED  # before these contacts: two cars touching now both move
        for a, b in contacts:
            for me, other in ((a, b), (b, a)):
                if me[0] != CAR:
                    continue
                i = me[1]
                if self.status[i] != ACTIVE:
                    continue
                self.status[i] = COLLIDED
                self.collided_with[i] = other[0]
                events.collided[i] = True
                events.collided_with[i] = other[0]
                if other[0] == CAR:
                    j = other[1]
                    self.collision_partner[i] = events.partner[i] = j
                    self.partner_halted[i] = events.partner_halted[i] = halted[j]
                events.substep[i] = substep
                hit.append(i)
        for i in hit:
            body = self.car_bodies[i]
            body.linearVelocity = (0.0, 0.0)
            self._standing[i] = True
            body.angularVelocity = 0.0
            self._angular[i] = 0.0
            self.speed[i] = 0.0
            if self.config.remove_collided:
                body.active = False
        return hit

    def _turn_pedestrians(self) -> None:
        """Pedestrians that walked past the end of their crossing turn back or stop there."""
        for k, body in enumerate(self.ped_bodies):
            y = body.position.y
            vy = self.ped_velocity[k, 1]
            lo, hi = self.ped_bounds[k]
            if (y > hi and vy > 0) or (y < lo and vy < 0):
                self.ped_velocity[k] *= -1.0 if self.ped_turn_back[k] else 0.0
                body.linearVelocity = tuple(self.ped_velocity[k])

    # -- reading ------------------------------------------------------------------------------
    def read_poses(self, cars: np.ndarray | None = None) -> None:
        """Cache car and pedestrian poses from Box2D (float64 copies): of every car, or only of
        ``cars`` (indices), the others keeping their last read. A car that did not move in a
        decision (halted, arrived or removed: zero velocity, no forces on a sensor body) has the
        pose Box2D would return, so reading only the cars that moved gives the same arrays."""
        bodies = self.car_bodies
        if cars is None:
            self._xy = [b.position.tuple for b in bodies]
            self._angle = [b.angle for b in bodies]
        else:
            xy, angle = self._xy, self._angle
            for i in cars.tolist():
                body = bodies[i]
                xy[i] = body.position.tuple
                angle[i] = body.angle
        # new arrays each time: callers may hold the previous decision's
        self.positions = np.array(self._xy, dtype=float).reshape(-1, 2)
        self.headings = wrap_angle(np.array(self._angle, dtype=float))
        self.ped_positions = np.array([b.position.tuple for b in self.ped_bodies],
                                      dtype=float).reshape(-1, 2)

    @property
    def present(self) -> np.ndarray:
        """Cars whose bodies are in the world (driving or halted; not arrived or removed)."""
        if self.config.remove_collided:
            return self.status == ACTIVE
        return self.status != ARRIVED


def _without(entries: list[tuple], car: int) -> list[tuple]:
    """``entries`` (tuples whose first item is a car index) without those of ``car``."""
    return [e for e in entries if e[0] != car]
