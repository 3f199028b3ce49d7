//! Point-cloud files → [`PointCloud`]. XYZ text now; PLY and LAS come with the point-cloud
//! renderer (issue 5), reusing the general PLY reader.

mod xyz;

pub use xyz::{parse_xyz, read_xyz};
