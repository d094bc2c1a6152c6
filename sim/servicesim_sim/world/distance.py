"""Distances across a map's free space and into its obstacles, worked out where they matter.

A map is mostly obstacle: the office's 1200 x 1200 grid holds its building in under a third of
its area, the rest is unknown or outside. The distance from each free cell to the nearest
blocked cell only ever looks as far as the blocked cells around the free space, so
:func:`distance_to_blocked` runs scipy's exact Euclidean distance transform on the free cells'
bounding box and the ring of cells around it, not on the whole grid, and gives every cell the
value the transform of the whole grid gives it.

Why the box gives the same values: a free cell's nearest blocked cell ``q`` outside the box
would lie beyond the ring, and the ring cell met by clamping ``q`` into the box is blocked
(no free cell lies outside the box) and no farther from the free cell than ``q`` is, along
either axis. Blocked cells are 0 in both. Where the box meets the edge of the grid there is no
ring on that side, and nothing beyond it for the whole grid's transform either.

:func:`depth_in_blocked` goes the other way, from blocked cells to the nearest free one: how
deep a point lies in a wall. Only depths near the free space are ever read (a body the physics
stops at the walls, and the poses navigation looks a few seconds ahead), so it runs the
transform on the free cells' bounding box grown by a reach, where every blocked cell finds its
nearest free cell as on the whole grid (every free cell lies in the box), and gives the cells
beyond the box the reach itself: they lie farther than that from any free cell.
"""

from __future__ import annotations

import numpy as np


def distance_to_blocked(free: np.ndarray) -> np.ndarray:
    """``scipy.ndimage.distance_transform_edt(free)``, in cells: for each free (True) cell the
    distance from its centre to the nearest blocked (False) cell's centre, 0 on blocked cells,
    worked out on the free cells' bounding box and its ring of cells."""
    from scipy import ndimage  # with the first transform: loading a world file needs none

    rows = np.flatnonzero(free.any(axis=1))
    distance = np.zeros(free.shape, dtype=np.float64)
    if rows.size == 0:
        return distance
    cols = np.flatnonzero(free.any(axis=0))
    box = (slice(max(int(rows[0]) - 1, 0), min(int(rows[-1]) + 2, free.shape[0])),
           slice(max(int(cols[0]) - 1, 0), min(int(cols[-1]) + 2, free.shape[1])))
    distance[box] = ndimage.distance_transform_edt(free[box])
    return distance


def depth_in_blocked(blocked: np.ndarray, *, reach: int) -> np.ndarray:
    """``scipy.ndimage.distance_transform_edt(blocked)``, in cells, wherever it is at most
    ``reach``: for each blocked (True) cell the distance from its centre to the nearest free
    (False) cell's centre, 0 on free cells. Cells farther than ``reach`` from every free cell
    may read ``reach`` instead (a lower bound of their depth); with no free cell every cell
    reads ``reach``."""
    from scipy import ndimage  # with the first transform: loading a world file needs none

    free = ~blocked
    rows = np.flatnonzero(free.any(axis=1))
    depth = np.full(blocked.shape, float(reach))
    if rows.size == 0:
        return depth
    cols = np.flatnonzero(free.any(axis=0))
    box = (slice(max(int(rows[0]) - reach, 0), min(int(rows[-1]) + reach + 1, blocked.shape[0])),
           slice(max(int(cols[0]) - reach, 0), min(int(cols[-1]) + reach + 1, blocked.shape[1])))
    depth[box] = ndimage.distance_transform_edt(blocked[box])
    return depth
