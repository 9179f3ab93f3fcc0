//! aisle-simulator
