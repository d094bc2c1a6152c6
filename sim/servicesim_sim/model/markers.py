"""What a 3D viewer should draw of the world: target areas, people, the guest, the robot's plan.

Pure descriptions, no ROS: :mod:`servicesim_sim.ros.marker_topics` turns them into
``visualization_msgs/MarkerArray`` messages, so that Foxglove's 3D panel (or RViz) shows the
building and everyone in it beside ``/tf`` and the map, live and in a run's recording.

A viewer keeps every marker it was sent until it is replaced (same namespace and id) or
deleted, so the ids are stable and nothing is ever left behind:

* every target area is a flat box (``areas``) with its name standing above it
  (``area_names``), the id its place in the world file; the task's pick-up, drop-off and start
  areas in colours of their own and their role after the name. The areas never change: they are
  described once (:func:`area_shapes`);
* every person is a cylinder (``people``) whose id is given the first time the name is seen and
  kept; a person no longer there is deleted. The guest is not among them: a blue cylinder of
  its own (``guest``, the colour of the shirt the camera shows) with its name above it. Only
  who moved is sent again, except that every :data:`FULL_EVERY`-th update sends everyone: a
  viewer that joined late, or seeks in a recording, has the whole crowd within that many
  updates. Thirty of the office's forty people stand still, and building and serialising a
  marker with rclpy cost the simulator about 45 µs (2-4 µs serialised by hand now,
  :mod:`servicesim_sim.wire.marker_messages`);
* the robot's planned path is one line strip (``plan``, id 0), sent again only when the plan
  changed and deleted when no goal runs.

:class:`SceneTracker` remembers what it sent and says, each time it is asked, what to add and
what to delete; its first answer starts by deleting everything a viewer may still hold from an
earlier simulator on the same topic.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import IntEnum

from servicesim_sim.model.people import IDLER
from servicesim_sim.world.files import AreaBox

Colour = tuple[float, float, float, float]  # red, green, blue, alpha in [0, 1]
Point2 = tuple[float, float]

AREAS_NS, AREA_NAMES_NS = "areas", "area_names"
PEOPLE_NS, GUEST_NS, GUEST_NAME_NS, PLAN_NS = "people", "guest", "guest_name", "plan"
GUEST_ROLE = "guest"  # the engine's role of the guest among the people
AREA_COLOUR: Colour = (0.55, 0.65, 0.75, 0.25)
TASK_AREA_COLOURS: Mapping[str, Colour] = {
    "pick-up": (0.2, 0.8, 0.3, 0.45),
    "drop-off": (1.0, 0.6, 0.1, 0.45),
    "start": (0.65, 0.35, 0.95, 0.45),
}
WALKER_COLOUR: Colour = (0.75, 0.75, 0.75, 1.0)
IDLER_COLOUR: Colour = (0.5, 0.5, 0.5, 1.0)
GUEST_COLOUR: Colour = (0.1, 0.35, 1.0, 1.0)
PLAN_COLOUR: Colour = (1.0, 0.2, 0.2, 0.9)
TEXT_COLOUR: Colour = (1.0, 1.0, 1.0, 1.0)
AREA_THICKNESS_M = 0.02
PERSON_DIAMETER_M = 0.5  # twice the referee's person body radius
PERSON_HEIGHT_M, GUEST_HEIGHT_M = 1.7, 1.5  # the camera draws the guest 1.5 m tall
TEXT_HEIGHT_M = 0.35  # of a capital letter
PLAN_WIDTH_M = 0.05
FULL_EVERY = 10  # updates (5 sim s at the simulator's 2 Hz)


class Kind(IntEnum):
    """The shapes drawn, numbered as ``visualization_msgs/Marker``'s types."""

    CUBE = 1
    CYLINDER = 3
    LINE_STRIP = 4
    TEXT_VIEW_FACING = 9


@dataclass(frozen=True)
class Shape:
    """One marker in the ``map`` frame: what it is, where, how big and in which colour."""

    namespace: str
    id: int
    kind: Kind
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    colour: Colour = TEXT_COLOUR
    text: str = ""
    points: tuple[Point2, ...] = ()
    z: float = 0.0  # of the points


@dataclass
class Update:
    """What one message carries: ``clear`` namespaces to empty first, then deletions, then
    shapes to add (or replace)."""

    clear: list[str] = field(default_factory=list)
    delete: list[tuple[str, int]] = field(default_factory=list)
    add: list[Shape] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.clear or self.delete or self.add)


# ------------------------------------------------------------------------------ the areas
def area_shapes(areas: Mapping[str, AreaBox], *, roles: Mapping[str, str]) -> list[Shape]:
    """A flat box and a name for every area, in the world's order; ``roles`` names the task's
    areas (``{"PublicCafe": "pick-up", ...}``), drawn in their role's colour."""
    shapes: list[Shape] = []
    for index, (name, box) in enumerate(areas.items()):
        role = roles.get(name)
        x, y = box.centre
        shapes.append(Shape(
            namespace=AREAS_NS, id=index, kind=Kind.CUBE,
            position=(x, y, AREA_THICKNESS_M / 2.0),
            scale=(box.width, box.height, AREA_THICKNESS_M),
            colour=TASK_AREA_COLOURS.get(role or "", AREA_COLOUR)))
        shapes.append(Shape(
            namespace=AREA_NAMES_NS, id=index, kind=Kind.TEXT_VIEW_FACING,
            position=(x, y, 0.5), scale=(0.0, 0.0, TEXT_HEIGHT_M),
            text=f"{name} ({role})" if role else name))
    return shapes


def areas_update(areas: Mapping[str, AreaBox], *, roles: Mapping[str, str]) -> Update:
    """The one message the areas need: whatever a viewer held in their namespaces, then them."""
    return Update(clear=[AREAS_NS, AREA_NAMES_NS], add=area_shapes(areas, roles=roles))


# ------------------------------------------------------------------------------ people and plan
def person_shape(person_id: int, *, role: str, x: float, y: float) -> Shape:
    colour = IDLER_COLOUR if role == IDLER else WALKER_COLOUR
    return Shape(namespace=PEOPLE_NS, id=person_id, kind=Kind.CYLINDER,
                 position=(x, y, PERSON_HEIGHT_M / 2.0),
                 scale=(PERSON_DIAMETER_M, PERSON_DIAMETER_M, PERSON_HEIGHT_M), colour=colour)


def guest_shapes(name: str, *, x: float, y: float) -> list[Shape]:
    return [
        Shape(namespace=GUEST_NS, id=0, kind=Kind.CYLINDER, position=(x, y, GUEST_HEIGHT_M / 2.0),
              scale=(PERSON_DIAMETER_M, PERSON_DIAMETER_M, GUEST_HEIGHT_M), colour=GUEST_COLOUR),
        Shape(namespace=GUEST_NAME_NS, id=0, kind=Kind.TEXT_VIEW_FACING,
              position=(x, y, GUEST_HEIGHT_M + 0.4), scale=(0.0, 0.0, TEXT_HEIGHT_M),
              text=f"guest {name}"),
    ]


def plan_shape(path: Sequence[Point2]) -> Shape:
    return Shape(namespace=PLAN_NS, id=0, kind=Kind.LINE_STRIP, scale=(PLAN_WIDTH_M, 0.0, 0.0),
                 colour=PLAN_COLOUR, points=tuple((float(x), float(y)) for x, y in path),
                 z=0.05)


class SceneTracker:
    """What changed among the people and the plan since the last update (module docstring)."""

    def __init__(self, *, full_every: int = FULL_EVERY) -> None:
        self.full_every = full_every
        self._ids: dict[str, int] = {}
        self._sent: dict[str, tuple[float, float]] = {}  # where each person was last sent
        self._guest: tuple[str, float, float] | None = None
        self._plan: tuple[Point2, ...] = ()
        self._updates = 0

    def update(self, people: Iterable[tuple[str, str, float, float]],
               plan: Sequence[Point2]) -> Update:
        """The message for now: ``people`` as (name, role, x, y), the guest's role ``guest``;
        ``plan`` the path the robot follows, empty when no goal runs."""
        update = Update()
        if self._updates == 0:
            update.clear = [PEOPLE_NS, GUEST_NS, GUEST_NAME_NS, PLAN_NS]
        full = self._updates % self.full_every == 0
        self._updates += 1
        present: dict[str, tuple[float, float]] = {}
        for name, role, x, y in people:
            if role == GUEST_ROLE:
                if full or self._guest != (name, x, y):
                    update.add += guest_shapes(name, x=x, y=y)
                self._guest = (name, x, y)
                continue
            present[name] = (x, y)
            if full or self._sent.get(name) != (x, y):
                person_id = self._ids.setdefault(name, len(self._ids))
                update.add.append(person_shape(person_id, role=role, x=x, y=y))
        update.delete += [(PEOPLE_NS, self._ids[name]) for name in sorted(self._sent)
                          if name not in present]
        self._sent = present
        self._update_plan(tuple((float(x), float(y)) for x, y in plan), update, full=full)
        return update

    def _update_plan(self, plan: tuple[Point2, ...], update: Update, *, full: bool) -> None:
        if plan == self._plan and not (full and plan):
            return
        if len(plan) >= 2:
            update.add.append(plan_shape(plan))
        elif self._plan:
            update.delete.append((PLAN_NS, 0))
        self._plan = plan if len(plan) >= 2 else ()
