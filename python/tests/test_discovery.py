"""Discovery by the contract of the Rust side: environment, run directory, owner records."""

import os
import tempfile
import unittest
from pathlib import Path

from aisle import discovery as d
from aisle.errors import DiscoveryError

HASH = "c322516854e43a21"


def record(prefix, root, **over):
    fields = dict(prefix=prefix, root=str(root), pid=1, mode="lockstep", seed=1, schema_hash=HASH, by="run")
    fields.update(over)
    return "".join(f'{k} = {v!r}\n'.replace("'", '"') if isinstance(v, str) else f"{k} = {v}\n" for k, v in fields.items())


class Discovery(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(dir="/tmp")
        self.run = Path(self.tmp.name)
        self.me = os.getpid(), d.start_time(os.getpid())

    def tearDown(self):
        self.tmp.cleanup()

    def instance(self, prefix, owner, text=None):
        root = self.run / prefix
        root.mkdir(mode=0o700)
        (root / d.OWNER_FILE).write_text(f"pid={owner[0]} start={owner[1]}\n")
        (root / d.INSTANCE_FILE).write_text(text if text is not None else record(prefix, root))
        return root

    def test_the_live_instance_is_found_and_dead_or_foreign_ones_are_not(self):
        self.instance("dead_", (self.me[0], self.me[1] + 1))
        self.instance("other_", self.me, record("elsewhere_", "/tmp/x"))
        live = self.instance("live_", self.me)
        found = d.find(environ={"AISLE_RUN_DIR": str(self.run)})
        self.assertEqual((found.prefix, found.root), ("live_", live))
        self.assertEqual(found.record.schema_hash, int(HASH, 16))
        self.assertEqual(found.record.mode, "lockstep")
        with self.assertRaisesRegex(DiscoveryError, "no live instance `dead_`.*live: live_"):
            d.find("dead_", environ={"AISLE_RUN_DIR": str(self.run)})
        _, unreadable = d.list_live(self.run)
        self.assertTrue(any("not its own directory" in u for u in unreadable), unreadable)

    def test_nothing_running_is_a_clear_error(self):
        with self.assertRaisesRegex(DiscoveryError, "no live aisle instance in .*aisle run"):
            d.find(environ={"AISLE_RUN_DIR": str(self.run)})

    def test_the_environment_wins_and_must_name_both(self):
        root = self.instance("named_", (1, 0))  # no live owner: named explicitly still counts
        found = d.find(environ={"AISLE_PREFIX": "named_", "AISLE_ROOT": str(root), "AISLE_RUN_DIR": "/nope"})
        self.assertEqual(found.prefix, "named_")
        with self.assertRaisesRegex(DiscoveryError, "AISLE_PREFIX is set but AISLE_ROOT is not"):
            d.find(environ={"AISLE_PREFIX": "named_"})
        with self.assertRaisesRegex(DiscoveryError, "prefix 'a/b'"):
            d.find("a/b", "/tmp")

    def test_run_dir_rules(self):
        self.assertEqual(d.run_dir({"AISLE_RUN_DIR": "/x/y"}), Path("/x/y"))
        with self.assertRaisesRegex(DiscoveryError, "AISLE_RUN_DIR is set but empty"):
            d.run_dir({"AISLE_RUN_DIR": ""})
        with self.assertRaisesRegex(DiscoveryError, "not an absolute path"):
            d.run_dir({"AISLE_RUN_DIR": "rel"})
        default = d.run_dir({})
        self.assertEqual(default.name, f"aisle-{os.geteuid()}")
        self.assertLessEqual(len(str(default)), 24)

    def test_bad_files_name_file_and_key(self):
        p = Path("/x/aisle-instance.toml")
        with self.assertRaisesRegex(DiscoveryError, "unknown key `color`"):
            d.parse_record(record("a_", "/r", color="red"), p)
        with self.assertRaisesRegex(DiscoveryError, "missing key `seed`"):
            d.parse_record('prefix="a"\nroot="/r"\npid=1\nmode="lockstep"\nschema_hash="%s"\nby="run"\n' % HASH, p)
        with self.assertRaisesRegex(DiscoveryError, "not 16 hex digits"):
            d.parse_record(record("a_", "/r", schema_hash="xyz"), p)
        with self.assertRaisesRegex(DiscoveryError, "aisle-instance.toml"):
            d.parse_record("prefix = ", p)
        self.assertEqual(d.parse_owner("pid=12 start=34\n"), (12, 34))
        self.assertIsNone(d.parse_owner("pid=12"))


if __name__ == "__main__":
    unittest.main()
