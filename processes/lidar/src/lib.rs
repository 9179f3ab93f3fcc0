//! aisle-lidar
