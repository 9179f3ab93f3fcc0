//! aisle-bus
