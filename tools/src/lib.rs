//! aisle-tools
