"""People read off navigation's costmap: a lethal disc in open floor is a person.

The costmap is drawn here as the simulator draws it (a person a disc of lethal cells 0.3 m
round their centre, inscribed cells out to 0.55 m; walls lethal to their faces), on a 10 x 6 m
room at 0.1 m, so every expected centre is where the test put someone.
"""

from __future__ import annotations

import numpy as np
import pytest

from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import (
    Costmap2D,
    people_on_costmap,
    people_within,
    window_of,
)
from tests.fakes.maps import costmap_of, grid_message

WIDTH, HEIGHT, RESOLUTION = 10.0, 6.0, 0.1


def walls() -> OccupancyGrid2D:
    """The static map: a room with 0.2 m walls round it, at the costmap's resolution."""
    values = np.zeros((round(HEIGHT / RESOLUTION), round(WIDTH / RESOLUTION)), dtype=np.int8)
    values[:2, :] = values[-2:, :] = values[:, :2] = values[:, -2:] = 100
    return OccupancyGrid2D.from_message(grid_message(values, resolution=RESOLUTION))


def costmap(people: list[tuple[float, float]]) -> Costmap2D:
    """The combined costmap over :func:`walls`, stamped at 12 s."""
    return costmap_of(walls(), people, stamp_s=12.0)


def test_each_person_is_found_where_they_stand_nearest_first() -> None:
    found = people_on_costmap(costmap([(6.0, 3.0), (3.0, 3.0)]), walls(), x=2.0, y=3.0,
                              reach=8.0)
    assert found == pytest.approx(np.array([[3.0, 3.0], [6.0, 3.0]]), abs=0.06)


def test_a_guest_and_the_walker_they_hold_up_a_metre_apart_are_two_people() -> None:
    found = people_on_costmap(costmap([(4.0, 3.0), (4.9, 3.3)]), walls(), x=4.0, y=2.0,
                              reach=5.0)
    assert len(found) == 2
    assert found == pytest.approx(np.array([[4.0, 3.0], [4.9, 3.3]]), abs=0.06)


def test_walls_are_nobody_and_a_person_against_a_wall_is_still_found() -> None:
    assert people_on_costmap(costmap([]), walls(), x=5.0, y=3.0, reach=10.0).shape == (0, 2)
    found = people_on_costmap(costmap([(5.0, 0.55)]), walls(), x=5.0, y=3.0, reach=10.0)
    assert len(found) == 1 and found[0] == pytest.approx([5.0, 0.55], abs=0.15)


def test_only_people_within_reach_count() -> None:
    everyone = costmap([(1.5, 3.0), (8.5, 3.0)])
    found = people_on_costmap(everyone, walls(), x=1.0, y=3.0, reach=3.0)
    assert found == pytest.approx(np.array([[1.5, 3.0]]), abs=0.06)
    assert people_on_costmap(everyone, walls(), x=40.0, y=40.0, reach=3.0).shape == (0, 2)


def test_people_within_a_radius_are_measured_from_their_centre_not_their_discs_edge() -> None:
    everyone = costmap([(4.0, 3.0), (6.05, 3.0), (5.0, 4.4)])
    found = people_within(everyone, walls(), x=5.0, y=3.0, radius=1.0)
    assert found == pytest.approx(np.array([[4.0, 3.0]]), abs=0.06)  # 6.05 is 1.05 m away
    two = people_within(everyone, walls(), x=5.0, y=3.0, radius=1.5)
    assert two == pytest.approx(np.array([[4.0, 3.0], [6.05, 3.0], [5.0, 4.4]]), abs=0.06)


def test_a_disc_the_circle_cuts_is_found_at_its_true_centre() -> None:
    found = people_within(costmap([(5.9, 3.0)]), walls(), x=5.0, y=3.0, radius=1.0)
    assert found == pytest.approx(np.array([[5.9, 3.0]]), abs=0.06)


def test_the_costmap_keeps_its_frame_and_stamp_and_a_broken_one_is_refused() -> None:
    drawn = costmap([(3.0, 3.0)])
    message = grid_message(drawn.values, resolution=RESOLUTION, origin=(-1.0, 2.0))
    message.header.stamp.sec, message.header.stamp.nanosec = 12, 500_000_000
    read = Costmap2D.from_message(message)
    assert read.values.tolist() == drawn.values.tolist()  # rows from the origin, as drawn
    assert (read.origin_x, read.origin_y) == (-1.0, 2.0)
    assert read.resolution == pytest.approx(RESOLUTION) and read.stamp_s == pytest.approx(12.5)
    broken = grid_message(np.zeros((3, 4), dtype=np.int8), resolution=RESOLUTION)
    broken.info.width = 5
    with pytest.raises(ValueError, match="5 x 3 cells with 12 values"):
        Costmap2D.from_message(broken)


def test_a_costmaps_repr_is_one_short_line_without_its_cells() -> None:
    """The tree log writes the repr of each new costmap on the blackboard, once a second."""
    costmap = Costmap2D(values=np.zeros((350, 360), dtype=np.int8), origin_x=-30.0,
                        origin_y=-30.0, resolution=0.05, stamp_s=12.5)
    text = repr(costmap)
    assert "stamp_s=12.5" in text and "values" not in text and "\n" not in text
    assert len(text) < 100


def _people_by_scipy(costmap: Costmap2D, walls: OccupancyGrid2D, *, x: float, y: float,
                     reach: float) -> np.ndarray:
    """The discs' centres as scipy's ``ndimage`` measures them over the whole window: the
    reference :func:`people_on_costmap` must equal bit for bit."""
    from scipy import ndimage

    bounds = window_of(costmap, x=x, y=y, reach=reach)  # the same window, measured by scipy
    if bounds is None:
        return np.zeros((0, 2))
    row0, row1, col0, col1 = bounds
    res = costmap.resolution
    grid_x, grid_y = np.meshgrid(costmap.origin_x + (np.arange(col0, col1) + 0.5) * res,
                                 costmap.origin_y + (np.arange(row0, row1) + 0.5) * res)
    window = ((costmap.values[row0:row1, col0:col1] >= 100)
              & (walls.clearances_at(grid_x, grid_y) > 0.15))
    labels, count = ndimage.label(window)
    index = np.arange(1, count + 1)
    sizes = ndimage.sum_labels(window, labels, index)
    centres = np.column_stack([ndimage.mean(grid_x, labels, index),
                               ndimage.mean(grid_y, labels, index)])[sizes >= 3]
    order = np.argsort(np.hypot(centres[:, 0] - x, centres[:, 1] - y), kind="stable")
    return centres[order].reshape(-1, 2)


@pytest.mark.parametrize("seed", range(40))
def test_the_centres_are_scipys_measurements_bit_for_bit(seed: int) -> None:
    random = np.random.default_rng(seed)
    people = [(float(random.uniform(0.2, WIDTH - 0.2)), float(random.uniform(0.2, HEIGHT - 0.2)))
              for _ in range(int(random.integers(0, 9)))]
    everyone = costmap_of(walls(), people, stamp_s=1.0)
    x, y = float(random.uniform(-1.0, WIDTH + 1.0)), float(random.uniform(-1.0, HEIGHT + 1.0))
    reach = float(random.uniform(0.3, 6.0))
    found = people_on_costmap(everyone, walls(), x=x, y=y, reach=reach)
    expected = _people_by_scipy(everyone, walls(), x=x, y=y, reach=reach)
    assert found.shape == expected.shape
    assert found.tobytes() == expected.tobytes()


def test_an_answer_on_the_latest_costmap_is_kept_until_another_costmap_comes() -> None:
    room, first = walls(), costmap([(3.0, 3.0)])
    found = people_on_costmap(first, room, x=2.0, y=3.0, reach=3.0)
    assert people_on_costmap(first, room, x=2.0, y=3.0, reach=3.0) is found
    assert not found.flags.writeable  # kept answers cannot be changed by whoever reads them
    assert people_on_costmap(first, room, x=2.0, y=3.0, reach=0.5).shape == (0, 2)
    moved = costmap([(4.0, 3.0)])  # the next costmap: the person walked on
    assert people_on_costmap(moved, room, x=2.0, y=3.0, reach=3.0) == pytest.approx(
        np.array([[4.0, 3.0]]), abs=0.06)
    assert people_on_costmap(moved, walls(), x=2.0, y=3.0, reach=3.0) is not found
