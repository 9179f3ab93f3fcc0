//! The drive direction of a reference section as the optimiser's arithmetic uses it.
//! Knows nothing else of sections.

use aisle_geometry::Direction;

/// Sign and kind of motion of a [`Direction`].
pub(crate) trait DriveSign {
    /// +1.0 forward, -1.0 reverse, 0.0 turning on the spot: the sign of the velocity
    /// along the heading.
    fn sign(self) -> f64;
    /// Whether the robot moves along its heading (forward or reverse), not on the spot.
    fn drives(self) -> bool;
}

impl DriveSign for Direction {
    fn sign(self) -> f64 {
        match self {
            Direction::Forward => 1.0,
            Direction::Reverse => -1.0,
            Direction::Rotate => 0.0,
        }
    }

    fn drives(self) -> bool {
        self != Direction::Rotate
    }
}
