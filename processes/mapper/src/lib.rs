//! aisle-mapper
