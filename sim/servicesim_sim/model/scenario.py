"""Scenarios: which task a simulator run plays, and how hard the world makes it.

A :class:`Scenario` is everything random about one run, drawn once from one seed: the pick-up
and drop-off areas, the guest's name and spot, the robot's start area and pose, the drift
schedule, and the seeds of the people and of the difficulty knobs. The same seed on the same
world always gives the same scenario; without a seed the world's fixed task (the shipped task
of the default office) is played, with the original's drift schedule parameters.

:class:`Difficulty` holds the knobs that make a run harder for the executive under test: a guest
placed beyond RFID range of the pick-up area's centre, earlier and more frequent drifts,
navigation goals that abort, RFID messages that are lost, and slow referee services. It also
carries ``guest_path``, the one deliberate difference of the guest from the original that can be
switched back: ``trail`` (the default) follows the robot's trail, ``straight`` walks straight at
the robot, through walls, as the original's guest did. ``walker_routes`` ``random`` gives every
walker a random loop of ours instead of the world's (the office: the original's).

scipy is imported where a task is drawn, not with the module: the command checks its arguments
(the difficulty among them) before it loads what only playing needs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from servicesim_sim.world.files import AreaBox, DriftSpec, TaskSpec, World

GUEST_PADDING_M = 1.0  # the original spawns the guest 1.0 m inside a room's area
NARROW_AREA_M = 2.0  # narrower than this (bathrooms, cubicle strips): the centre line instead
PERSON_CLEARANCE_M = 0.45  # a spot for a person or the robot: this far from any wall
RFID_RANGE_M = 2.0
OUT_OF_RANGE_M = (2.6, 5.0)  # how far from the area centre an out-of-range guest stands
START_GUEST_CLEARANCE_M = 1.5  # the robot's start pose keeps this far from the guest
START_EDGE_MARGIN_M = 0.4  # and this far inside its area: a return within the 0.3 m goal
# tolerance of the start pose must still put the robot's origin in the area (checkpoint 4)
SHIPPED_DRIFT_SEED = 100  # the shipped task's people and knobs: the seed the original's shipped
# world was generated with (its drift times are in the world file, `drift.times`)


@dataclass(frozen=True)
class Difficulty:
    """Knobs that make the world harder for the executive; the defaults are the original's,
    but for ``guest_path`` (see the module docstring)."""

    guest_out_of_range: bool = False
    drift_scale: float = 1.0  # < 1: earlier and more frequent drifts
    nav_abort_probability: float = 0.0
    rfid_dropout: float = 0.0  # probability that one RFID message is lost
    service_latency_s: float = 0.0  # sim seconds before a referee service answers
    odom_drift: float = 0.0  # encoder calibration error (std of the scale factors' offsets)
    localisation_noise: float = 0.0  # m (and rad): std of the noise on a converged estimate
    guest_path: str = "trail"  # how the guest follows: "trail" (ours) or "straight" (original)
    walker_routes: str = "world"  # "world": the world's loops (the original's); "random": ours

    @classmethod
    def default(cls) -> Difficulty:
        return cls()

    @classmethod
    def hard(cls) -> Difficulty:
        """The evaluation's ``hard`` set: every knob turned up at once."""
        return cls(guest_out_of_range=True, drift_scale=0.25, nav_abort_probability=0.15,
                   rfid_dropout=0.2, service_latency_s=0.2)


@dataclass(frozen=True)
class Scenario:
    """One run's task and random draws."""

    task: TaskSpec
    drift_times: tuple[float, ...]  # world sim seconds (not counted from new_task)
    people_seed: int
    knob_seed: int
    difficulty: Difficulty
    seed: int | None


class ScenarioError(ValueError):
    """The world cannot host a task (too few areas, no free spot); one line."""


def make_scenario(world: World, *, seed: int | None = None,
                  difficulty: Difficulty | None = None, draw: int = 0) -> Scenario:
    """The world's fixed task without a seed (if it has one), else a task drawn from ``seed``.

    ``draw`` > 0 draws again, deterministically (:mod:`servicesim_sim.model.playable` does
    while a draw cannot be played): another task of the seed, or the fixed task with other
    people and knobs."""
    difficulty = difficulty or Difficulty.default()
    again = [draw] if draw else []
    if seed is None and world.task is not None:
        return _fixed_scenario(world, difficulty, again=again)
    rng = np.random.default_rng([0 if seed is None else seed, 1, *again])
    free = _spot_mask(world)
    pick_up, drop_off, start_area = _three_areas(world, rng, seeded=seed is not None)
    guest_x, guest_y = _guest_spot(world, world.areas[pick_up], free, rng, difficulty)
    start_x, start_y = _start_spot(world, world.areas[start_area], free, rng,
                                   guest=(guest_x, guest_y))
    task = TaskSpec(
        pick_up=pick_up, drop_off=drop_off, guest_name=person_name(rng),
        guest_x=guest_x, guest_y=guest_y, guest_yaw=float(rng.uniform(-math.pi, math.pi)),
        start_area=start_area, start_x=start_x, start_y=start_y,
        start_yaw=float(rng.uniform(-math.pi, math.pi)),
    )
    return Scenario(
        task=task, drift_times=drift_schedule(world.drift, rng=rng, scale=difficulty.drift_scale),
        people_seed=int(rng.integers(2**31)), knob_seed=int(rng.integers(2**31)),
        difficulty=difficulty, seed=seed,
    )


def person_name(rng: np.random.Generator) -> str:
    """``human_NNNNN``, as every person in the original is named."""
    return f"human_{int(rng.integers(10000, 100000)):05d}"


def drift_schedule(spec: DriftSpec, *, rng: np.random.Generator,
                   scale: float = 1.0) -> tuple[float, ...]:
    """Drift times in absolute world sim seconds, as the original's world template drew them:
    none before ``start_s``; the first ``min..max`` seconds after it, each next one ``min..max``
    seconds after the one before. ``scale`` shrinks (< 1) or stretches the whole schedule,
    ``start_s`` and the intervals alike.

    Like Ruby's ``rand(min..max)`` in the template (``worlds/service.world.erb`` 360-363), an
    interval between whole numbers of seconds is a whole number of seconds, each as likely
    (the floor of a uniform draw over min..max + 1: one draw an interval)."""
    whole = spec.min_interval_s.is_integer() and spec.max_interval_s.is_integer()
    times, now = [], spec.start_s
    for _ in range(spec.count):
        if whole:
            now += math.floor(rng.uniform(spec.min_interval_s, spec.max_interval_s + 1.0))
        else:
            now += float(rng.uniform(spec.min_interval_s, spec.max_interval_s))
        times.append(round(now * scale, 3))
    return tuple(times)


def fixed_drift_times(spec: DriftSpec, *, scale: float = 1.0) -> tuple[float, ...] | None:
    """The world's own schedule for its fixed task, scaled as a drawn one would be."""
    if spec.times is None:
        return None
    return tuple(round(time * scale, 3) for time in spec.times)


def _fixed_scenario(world: World, difficulty: Difficulty, *, again: list[int]) -> Scenario:
    task = world.task
    assert task is not None
    rng = np.random.default_rng([SHIPPED_DRIFT_SEED, 1, *again])
    if difficulty.guest_out_of_range:
        guest_x, guest_y = _out_of_range_spot(world, world.areas[task.pick_up],
                                              _spot_mask(world), rng)
        task = dataclasses.replace(task, guest_x=guest_x, guest_y=guest_y)
    fixed = fixed_drift_times(world.drift, scale=difficulty.drift_scale)
    return Scenario(
        task=task, drift_times=fixed if fixed is not None else drift_schedule(
            world.drift, rng=rng, scale=difficulty.drift_scale),
        people_seed=int(rng.integers(2**31)), knob_seed=int(rng.integers(2**31)),
        difficulty=difficulty, seed=None,
    )


def _three_areas(world: World, rng: np.random.Generator, *,
                 seeded: bool) -> tuple[str, str, str]:
    targets = list(world.targets)
    if len(targets) < 3:
        why = "a random task (a seed)" if seeded else "with no fixed task (task:), a random task"
        raise ScenarioError(f"{world.path}: {why} needs 3 target areas (pick-up, drop-off, "
                            f"start); the world offers {len(targets)}")
    chosen = rng.choice(len(targets), size=3, replace=False)
    pick_up, drop_off, start = (targets[int(index)] for index in chosen)
    return pick_up, drop_off, start


def _spot_mask(world: World) -> np.ndarray:
    """Cells where a person or the robot may stand: free and clear of walls."""
    return world.map.wall_distance >= PERSON_CLEARANCE_M


def _free(world: World, free: np.ndarray, x: float, y: float) -> bool:
    row, col = world.map.world_to_cell(x, y)
    return world.map.in_bounds(row, col) and bool(free[row, col])


def _guest_spot(world: World, box: AreaBox, free: np.ndarray, rng: np.random.Generator,
                difficulty: Difficulty) -> tuple[float, float]:
    if difficulty.guest_out_of_range:
        return _out_of_range_spot(world, box, free, rng)
    for _ in range(200):
        x, y = _padded_point(box, rng)
        if _free(world, free, x, y):
            return x, y
    return _nearest_spot(world, box, free, rng)


def _padded_point(box: AreaBox, rng: np.random.Generator) -> tuple[float, float]:
    """A random point 1.0 m inside a room's box; on the centre line of a narrow one."""
    centre_x, centre_y = box.centre

    def along(low: float, high: float, centre: float) -> float:
        if high - low <= NARROW_AREA_M:
            return centre
        return float(rng.uniform(low + GUEST_PADDING_M, high - GUEST_PADDING_M))

    return along(box.min_x, box.max_x, centre_x), along(box.min_y, box.max_y, centre_y)


def _out_of_range_spot(world: World, box: AreaBox, free: np.ndarray,
                       rng: np.random.Generator) -> tuple[float, float]:
    """A free spot 2.6-5 m from the area centre, reachable from it: beyond RFID range."""
    centre_x, centre_y = box.centre
    reachable = _reachable_from(world, free, centre_x, centre_y)
    for _ in range(500):
        distance = float(rng.uniform(*OUT_OF_RANGE_M))
        angle = float(rng.uniform(-math.pi, math.pi))
        x, y = centre_x + distance * math.cos(angle), centre_y + distance * math.sin(angle)
        if _free(world, reachable, x, y):
            return round(x, 3), round(y, 3)
    low, high = OUT_OF_RANGE_M
    raise ScenarioError(f"{world.path}: no free spot {low:g}-{high:g} m from the centre of area "
                        f"{_area_label(world, box)} for a guest out of RFID range")


def _reachable_from(world: World, free: np.ndarray, x: float, y: float) -> np.ndarray:
    from scipy import ndimage  # with the task, not with the module: see the module docstring

    labels, _ = ndimage.label(free)
    row, col = world.map.world_to_cell(x, y)
    if not world.map.in_bounds(row, col) or labels[row, col] == 0:
        return free
    reachable: NDArray[np.bool_] = labels == labels[row, col]
    return reachable


def _start_spot(world: World, box: AreaBox, free: np.ndarray, rng: np.random.Generator,
                *, guest: tuple[float, float]) -> tuple[float, float]:
    """The area's pivot: its centre, or the free spot in it nearest the centre; in either case
    :data:`START_GUEST_CLEARANCE_M` from the guest where the area allows (target areas can
    adjoin, and a robot started on the guest's toes books contact before it moves), and
    :data:`START_EDGE_MARGIN_M` inside the area's edges (a quarter of a narrow side at most)."""
    centre = box.centre
    if _free(world, free, *centre) and math.dist(centre, guest) >= START_GUEST_CLEARANCE_M:
        return round(centre[0], 3), round(centre[1], 3)
    margin = min(START_EDGE_MARGIN_M, box.width / 4.0, box.height / 4.0)
    try:
        return _sampled_spot(world, box, free, rng, cost=lambda x, y: math.dist((x, y), centre),
                             allowed=lambda x, y: box.contains(x, y, margin) and math.dist(
                                 (x, y), guest) >= START_GUEST_CLEARANCE_M)
    except ScenarioError:  # a small area next to the guest: as far from them as it allows
        return _sampled_spot(world, box, free, rng, cost=lambda x, y: -math.dist((x, y), guest),
                             allowed=lambda x, y: box.contains(x, y, margin))


def _nearest_spot(world: World, box: AreaBox, free: np.ndarray,
                  rng: np.random.Generator) -> tuple[float, float]:
    centre = box.centre
    return _sampled_spot(world, box, free, rng, cost=lambda x, y: math.dist((x, y), centre))


def _sampled_spot(world: World, box: AreaBox, free: np.ndarray, rng: np.random.Generator, *,
                  cost: Callable[[float, float], float],
                  allowed: Callable[[float, float], bool] = lambda x, y: True,
                  ) -> tuple[float, float]:
    """Of 400 random points in the box, the free and allowed one of least ``cost``."""
    best: tuple[float, float, float] | None = None
    for _ in range(400):
        x = float(rng.uniform(box.min_x, box.max_x))
        y = float(rng.uniform(box.min_y, box.max_y))
        if not (_free(world, free, x, y) and allowed(x, y)):
            continue
        value = cost(x, y)
        if best is None or value < best[0]:
            best = (value, x, y)
    if best is None:
        raise ScenarioError(f"{world.path}: no free spot {PERSON_CLEARANCE_M:g} m from walls, "
                            f"for a person or the robot, inside area {_area_label(world, box)}")
    return round(best[1], 3), round(best[2], 3)


def _area_label(world: World, box: AreaBox) -> str:
    """The area's name and box, for a message."""
    name = next((name for name, area in world.areas.items() if area == box), "?")
    return f"{name!r} (x {box.min_x:g}..{box.max_x:g}, y {box.min_y:g}..{box.max_y:g})"

