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
    """An `OccupancyGrid`'s `height x width` cells as uint8 (row-major), without copying."""
    m = _message(sample)
    n = int(m.width) * int(m.height)
    if n > len(m.cells):
        raise ValueError(f"OccupancyGrid says {m.width} x {m.height} cells, it holds at most {len(m.cells)}")
    return np.ctypeslib.as_array(m.cells)[:n].reshape(int(m.height), int(m.width))


def address(sample) -> int:
    """The address of the message (to check that a view shares the sample's memory)."""
    return ctypes.addressof(_message(sample))
