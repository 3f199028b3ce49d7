//! Command-line syntax (clap derive).

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "glint",
    version,
    about = "A fast CPU renderer: Whitted ray tracing (path tracing, point clouds and skies to come)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (.toml) or a model file (.obj, .ply, .gltf, .glb); the demo scene without one.
    Render(RenderArgs),
    /// Benchmarks (ray throughput, Whitted frames).
    #[command(subcommand)]
    Bench(BenchCommand),
}

#[derive(Args, Debug, Clone, Default)]
pub struct CameraArgs {
    /// Camera position "X,Y,Z" (overrides the scene's camera).
    #[arg(long, value_name = "X,Y,Z")]
    pub eye: Option<String>,
    /// Point the camera looks at "X,Y,Z".
    #[arg(long = "look-at", value_name = "X,Y,Z")]
    pub look_at: Option<String>,
    /// Up direction "X,Y,Z".
    #[arg(long, value_name = "X,Y,Z")]
    pub up: Option<String>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f32>,
}

#[derive(Args, Debug, Clone, Default)]
pub struct RenderArgs {
    /// Scene or model file; omitted: the built-in demo scene.
    pub input: Option<PathBuf>,
    /// Output image: .png (tone-mapped sRGB) or .exr (linear float, with AOVs).
    #[arg(short, long, default_value = "glint.png")]
    pub output: PathBuf,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel, a square number (N×N stratified supersampling): 1, 4, 9, 16, ...
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads (default: every core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of every random number in the render.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Maximum ray depth (reflection/refraction bounces).
    #[arg(long = "max-depth")]
    pub max_depth: Option<u32>,
    /// Exposure in stops (PNG output).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f32,
    /// Tone map for PNG output: clamp, reinhard or aces.
    #[arg(long, default_value = "clamp")]
    pub tonemap: String,
    /// Write RGBA PNG with coverage as alpha.
    #[arg(long)]
    pub alpha: bool,
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Print no progress bar or summary.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RayKind {
    /// Camera rays through pixel centres.
    Primary,
    /// Cosine-distributed bounce rays from the primary hits.
    Diffuse,
    /// Any-hit rays from the primary hits toward the first light.
    Shadow,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScheduleArg {
    Stealing,
    Static,
}

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Time traversal over a fixed set of rays; optionally dump them for ../shared/bench (Embree).
    Rays(BenchRaysArgs),
    /// Time Whitted frames (the thesis's benchmark scene by default).
    Whitted(BenchWhittedArgs),
}

#[derive(Args, Debug)]
pub struct BenchRaysArgs {
    /// Scene or model file.
    #[arg(long)]
    pub scene: PathBuf,
    #[arg(long, value_enum, default_value = "primary")]
    pub kind: RayKind,
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    #[arg(long, default_value_t = 768)]
    pub height: u32,
    /// Timed passes over the rays (the median is reported).
    #[arg(long, default_value_t = 7)]
    pub reps: usize,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write PREFIX.tris.f32, PREFIX.rays.f32 and PREFIX.hits.f32 for the Embree scripts.
    #[arg(long)]
    pub dump: Option<PathBuf>,
    /// Split every triangle into 4^N before building (e.g. 2: the 100k dragon becomes 1.6 M).
    #[arg(long, default_value_t = 0)]
    pub subdivide: u32,
}

#[derive(Args, Debug)]
pub struct BenchWhittedArgs {
    /// Scene (default: scenes/whitted-bench.toml's embedded copy).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    #[arg(long, default_value_t = 720)]
    pub height: u32,
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    #[arg(long, value_enum, default_value = "stealing")]
    pub schedule: ScheduleArg,
}
