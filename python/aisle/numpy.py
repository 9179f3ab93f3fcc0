"""NumPy views of message arrays over the message's own memory (no copy).

`points(msg)` is an `(rows * cols, 3)` float32 array over a `PointCloud`'s points: valid
as long as that memory is: for a copy (`Subscriber.receive()`), as long as the copy lives
(the array keeps it alive); for a `View` (`Subscriber.receive_view()`), only until the view
is released, after which the array must not be used (the sample goes back to the publisher).
"""

from __future__ import annotations

import ctypes

import numpy as np

from .bus import View


def _message(sample):
    return sample.msg if isinstance(sample, View) else sample


def points(sample, organised: bool = False) -> np.ndarray:
    """The cloud's `rows * cols` points as float32 `(n, 3)` (or `(rows, cols, 3)`), NaN
    for no return, without copying."""
    m = _message(sample)
    n = int(m.rows) * int(m.cols)
    cap = len(m.points)
    if n > cap:
        raise ValueError(f"PointCloud says {m.rows} x {m.cols} points, it holds at most {cap}")
    arr = np.ctypeslib.as_array(m.points)[:n]  # shares memory; keeps `m` alive
    return arr.reshape(int(m.rows), int(m.cols), 3) if organised else arr


def cells(sample) -> np.ndarray:
    """A grid's (`OccupancyGrid`, the local map, or `GlobalGrid`, the global map)
    `height x width` cells as uint8 (row-major), without copying."""
    m = _message(sample)
    n = int(m.width) * int(m.height)
    if n > len(m.cells):
        raise ValueError(f"the grid says {m.width} x {m.height} cells, it holds at most {len(m.cells)}")
    return np.ctypeslib.as_array(m.cells)[:n].reshape(int(m.height), int(m.width))


class GlobalMap:
    """The global map as the newest full map (`topics.GLOBAL_MAP`) and the newest changes
    since it (`topics.GLOBAL_MAP_CHANGES`) make it, as the Rust nodes hold it
    (`aisle_messages::GlobalMapCopy`).

    The mapper sends the whole map at start and when its changes outgrow a
    `MapChanges`; in between only the changes, each message listing every cell changed
    since that full map with its value now. So the newest message of each topic is all a
    holder needs: call `update(full, changes)` with whatever arrived (either may be None).
    `cells` is a `(height, width)` uint8 copy (0 free, 1 static, 2 detected).
    """

    def __init__(self):
        self.cells = None
        self.base_version = None
        self.version = 0
        self.origin = (0.0, 0.0)
        self.resolution = 0.0

    def update(self, full=None, changes=None) -> bool:
        """Takes what newly arrived (each message once, as `Subscriber.latest()` gives
        it): a full map is copied whatever its version (a mapper started afresh counts
        from 0 again), then changes that name the held full map and are newer than the
        copy are applied; returns whether the map changed. Raises ValueError for changes
        that do not fit the map (nothing is written)."""
        changed = False
        if full is not None:
            f = _message(full)
            self.cells = cells(f).copy()
            self.base_version = self.version = int(f.version)
            self.origin = (float(f.origin_x), float(f.origin_y))
            self.resolution = float(f.resolution)
            changed = True
        if changes is not None and self.cells is not None:
            c = _message(changes)
            if int(c.base_version) == self.base_version and int(c.version) > self.version:
                self._apply(c)
                changed = True
        return changed

    def _apply(self, c):
        h, w = self.cells.shape
        if (int(c.height), int(c.width)) != (h, w):
            raise ValueError(f"changes for a {c.width} x {c.height} map, the held one is {w} x {h}")
        n = int(c.len)
        if n > len(c.changes):
            raise ValueError(f"{n} changes listed, a MapChanges holds at most {len(c.changes)}")
        entries = np.ctypeslib.as_array(c.changes)[:n] if n else None
        if entries is None:
            self.version = int(c.version)
            return
        index, value = entries["index"].astype(np.int64), entries["value"]
        if (index >= h * w).any():
            raise ValueError(f"a change names a cell past the map's {h * w}")
        self.cells.reshape(-1)[index] = value
        self.version = int(c.version)


def address(sample) -> int:
    """The address of the message (to check that a view shares the sample's memory)."""
    return ctypes.addressof(_message(sample))
