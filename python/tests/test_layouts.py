"""The generated layouts: import-time checks hold, and spot values match the Rust catalogue."""

import ctypes
import unittest

import aisle
from aisle import messages as m


class Layouts(unittest.TestCase):
    def test_every_structure_has_rusts_size_offsets_and_type_name(self):
        self.assertEqual(len(m.LAYOUTS), 30)
        for cls, (size, align, fields) in m.LAYOUTS.items():
            self.assertEqual(ctypes.sizeof(cls), size, cls.TYPE_NAME)
            self.assertEqual(ctypes.alignment(cls), align, cls.TYPE_NAME)
            self.assertEqual(cls.type_name(), cls.TYPE_NAME)
            for name, offset, fsize in fields:
                self.assertEqual((getattr(cls, name).offset, getattr(cls, name).size), (offset, fsize))

    def test_spot_values(self):
        self.assertEqual(ctypes.sizeof(m.RobotState), 128)
        self.assertEqual(m.RobotState.pose.offset, 48)
        self.assertEqual(m.RobotState.TYPE_NAME, "aisle.RobotState.v1")
        self.assertEqual(ctypes.sizeof(m.PointCloud), 1573000)
        self.assertEqual(m.StageStatus.Done, 0)
        self.assertEqual(m.DockMove.None_, 0)
        self.assertEqual(m.STAGE_CONTROLLER, 1)
        self.assertEqual(m.BUILTIN_NODES["teb_controller"], 5)
        self.assertEqual(len(aisle.SCHEMA_HASH_HEX), 16)
        self.assertIs(aisle.topics.ROBOT_STATE.message, m.RobotState)
        self.assertEqual(aisle.topics.by_name("aisle/tick"), aisle.topics.TICK)

    def test_node_codes(self):
        self.assertEqual(aisle.node_code("lidar"), 2)
        # FNV-1a 32 of "a" is 0xe40c292c; bit 31 marks an external node.
        self.assertEqual(aisle.node_code("a"), 0x8000_0000 | (0xE40C292C & 0x7FFF_FFFF))
        self.assertEqual(aisle.node_code(""), 0x8000_0000 | (0x811C9DC5 & 0x7FFF_FFFF))


class NumpyView(unittest.TestCase):
    def test_points_share_the_message_memory(self):
        try:
            import aisle.numpy as anp
        except ImportError:
            self.skipTest("numpy is not installed")
        cloud = m.PointCloud()
        cloud.rows, cloud.cols = 2, 3
        pts = anp.points(cloud)
        self.assertEqual(pts.shape, (6, 3))
        pts[4, 1] = 7.5  # written through the view
        self.assertEqual(cloud.points[4][1], 7.5)
        self.assertEqual(anp.points(cloud, organised=True).shape, (2, 3, 3))
        self.assertEqual(pts.ctypes.data, anp.address(cloud) + m.PointCloud.points.offset)
        cloud.rows, cloud.cols = 1000, 1000
        with self.assertRaises(ValueError):
            anp.points(cloud)


    def test_the_global_map_is_its_full_map_with_the_newest_changes(self):
        try:
            import aisle.numpy as anp
        except ImportError:
            self.skipTest("numpy is not installed")
        full = m.GlobalGrid()
        full.width, full.height, full.resolution, full.version = 3, 2, 0.1, 4
        full.cells[2] = 1
        changes = m.MapChanges()
        changes.base_version, changes.version, changes.width, changes.height = 4, 6, 3, 2
        changes.len = 2
        changes.changes[0].index, changes.changes[0].value = 1, 2
        changes.changes[1].index, changes.changes[1].value = 5, 2
        g = anp.GlobalMap()
        self.assertFalse(g.update(None, changes))  # waits for its full map
        self.assertTrue(g.update(full, changes))
        self.assertEqual(g.cells.tolist(), [[0, 2, 1], [0, 0, 2]])
        self.assertEqual((g.base_version, g.version), (4, 6))
        self.assertFalse(g.update(None, changes))  # nothing new
        changes.version, changes.changes[1].value = 7, 0
        self.assertTrue(g.update(None, changes))
        self.assertEqual(g.cells.tolist(), [[0, 2, 1], [0, 0, 0]])
        changes.version, changes.changes[0].index = 8, 6
        with self.assertRaises(ValueError):
            g.update(None, changes)


if __name__ == "__main__":
    unittest.main()
