"""An external node: republishes each tick's RobotState unchanged on `user/robot_pose`,
stamped as its own output of that tick.

Declare it in graph.toml (the supervisor starts it with the AISLE_* environment):

    [[topic]]
    name = "user/robot_pose"
    type = "aisle.RobotState.v1"

    [[node]]
    name = "pose_republisher"
    command = ["python3", "python/examples/pose_republisher.py"]
    publishes = ["user/robot_pose"]
    subscribes = ["aisle/tick", "aisle/robot_state"]
    acknowledges = "every_tick"
"""

import sys

import aisle
from aisle.messages import RobotState


@aisle.stage
def republish(tick, inputs):
    state = inputs[aisle.topics.ROBOT_STATE]
    if state is None:  # nothing published yet for a tick <= this one
        return None
    assert isinstance(state, RobotState)
    return {"user/robot_pose": state}


if __name__ == "__main__":
    sys.exit(republish.run())
