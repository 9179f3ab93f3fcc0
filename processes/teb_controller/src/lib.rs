//! aisle-teb-controller
