//! glint-scene: the validated, immutable scene every mode renders.
//!
//! Camera, shapes (sphere, plane, triangle mesh), point clouds, materials, textures, lights,
//! the sky, and simple animations of objects and lights.
//! Built by glint-formats from files (or by code), checked once by [`Scene::validate`], then
//! read-only: integrators never see an invalid value, so hot paths need no `Result`.
//! Depends on glint-core and glint-image only; knows nothing of acceleration structures.
// One measured hot kernel (the sky's SIMD texel filter) allows unsafe, with its SAFETY note.
#![deny(unsafe_code)]

pub mod animation;
pub mod bsdf;
pub mod camera;
pub mod error;
pub mod light;
pub mod limits;
pub mod material;
pub mod mesh;
pub mod object;
pub mod points;
pub mod presets;
pub mod scene;
pub mod sky;
pub mod texture;

pub use animation::{Animation, AnimationBase, AnimationTarget, Keyframes, Motion, Repeat, Rotation};
pub use bsdf::{BsdfId, BsdfKind, Distribution, Principled, Roughness, Tex};
pub use camera::{Camera, CameraRays, Fov, Lens, ViewSize};
pub use error::SceneError;
pub use light::{Attenuation, Light, SpotFalloff, SpotProjection};
pub use material::Material;
pub use mesh::{MAX_COORDINATE, Mesh, MeshAttribute};
pub use object::{CloudObject, Object, Shape};
pub use points::{EstimateSettings, Orientation, PointCloud, estimate_normals, estimate_radii, prepare, sample_mesh};
pub use scene::{RenderDefaults, RenderMode, Scene};
pub use sky::{
    CubeFace, CubeMap, IrradianceSh, LatLongMap, Sky, SkySample, SkySampler, SkyTransform, cube_direction,
    cube_face_st, latlong_direction, latlong_uv,
};
pub use texture::{Filter, Sampler, Texture, TextureImage, Wrap};
