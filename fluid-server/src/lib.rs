//! placeholder
pub mod gpu;
pub mod neighbour_grid;
pub mod prefix_sum;
pub mod shaders;
pub mod timing;
