//! aisle-supervisor
