//! The batched Whitted tracer (pipeline: band driver → **tiles of ray streams** → film): rays
//! are made, traced and shaded eight at a time in structure of arrays.
//!
//! A band of rows is cut into tiles of 16 × 8 pixels. A tile's primary rays (every sample of
//! every pixel) form the first stream, in 4 × 2 pixel packets so that the eight lanes of a
//! batch are coherent. Each depth level is one pass over its stream: eight rays at a time are
//! intersected (`World::intersect_batch`), the missing lanes see the sky, the hit lanes are
//! shaded (`shade8.rs`: Phong with one shadow packet per light) and spawn their reflected and
//! refracted rays into the next level's stream, compacted, so lanes stay full however the
//! trees diverge. A tile's sample sums are then resolved into its pixels exactly as the scalar
//! tracer's driver does (NaN samples dropped, AOVs from each sample's first hit).
//!
//! Each sample's colour is a sum of the same contributions as in the scalar tracer; only their
//! order differs (depth by depth instead of the scalar stack's), and the Phong power is a
//! polynomial: the pictures agree to well below one 8-bit step (tested on every scene).

use super::shade8::{MaterialTable, Shading, ShadowLight, shade, sky8};
use super::{PixelAccumulator, Samples};
use crate::film::{FilmPixel, FilmRows, MAX_SAMPLE_RADIANCE, SurfacePixel};
use crate::settings::{ImageSettings, WhittedSettings};
use crate::stats::{BandStats, RayCounts};
use crate::world::{PointCones, World};
use glint_accel::batch::Rays8;
use glint_accel::lanes::{F8, Isa, LANES, M8, U8x, V8};
use glint_core::random::SampleStream;
use glint_core::sampling::stratified_2d;
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::{Camera, CameraRays};

/// Tile width in pixels (a tile is one band of rows high).
pub(super) const TILE_W: usize = 16;

/// The per-lane state of a batch of rays beside the rays themselves.
pub(super) struct Lanes<I: Isa> {
    pub weight: V8<I>,
    /// Ray cone: footprint width at the origin and spread angle.
    pub width: F8<I>,
    pub spread: F8<I>,
    /// The sample (within the tile) whose tree the ray belongs to.
    pub sample: U8x<I>,
}

/// Eight rays of a stream with their lane state (one block of the stream's storage), as
/// plain arrays: a block is loaded into lanes and stored from them whole.
#[derive(Clone, Copy, Default)]
struct Block {
    origin: [[f32; LANES]; 3],
    dir: [[f32; LANES]; 3],
    weight: [[f32; LANES]; 3],
    width: [f32; LANES],
    spread: [f32; LANES],
    sample: [u32; LANES],
}

/// The rays of one depth level of a tile, in blocks of eight (structure of arrays inside a
/// block): a batch is one block; spawned rays are appended lane by lane, so the blocks stay
/// full however the trees diverge.
#[derive(Default)]
pub(super) struct Stream {
    blocks: Vec<Block>,
    len: usize,
}

#[inline(always)]
fn store3<I: Isa>(v: V8<I>) -> [[f32; LANES]; 3] {
    [v.x.to_array(), v.y.to_array(), v.z.to_array()]
}

#[inline(always)]
fn load3<I: Isa>(a: &[[f32; LANES]; 3]) -> V8<I> {
    V8::new(F8::from_array(a[0]), F8::from_array(a[1]), F8::from_array(a[2]))
}

impl Stream {
    fn clear(&mut self) {
        self.len = 0;
    }

    fn len(&self) -> usize {
        self.len
    }

    /// Append the `lanes` of a batch, in lane order.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn push_lanes<I: Isa>(
        &mut self,
        lanes: M8<I>,
        origin: V8<I>,
        dir: V8<I>,
        weight: V8<I>,
        width: F8<I>,
        spread: F8<I>,
        sample: U8x<I>,
    ) {
        let bits = lanes.bits();
        let count = bits.count_ones() as usize;
        let needed = (self.len + count).div_ceil(LANES);
        if self.blocks.len() < needed {
            self.blocks.resize(needed, Block::default());
        }
        if count == LANES && self.len.is_multiple_of(LANES) {
            let b = &mut self.blocks[self.len / LANES];
            (b.origin, b.dir, b.weight) = (store3(origin), store3(dir), store3(weight));
            (b.width, b.spread, b.sample) = (width.to_array(), spread.to_array(), sample.to_array());
            self.len += LANES;
            return;
        }
        let (o, d, w) = (store3(origin), store3(dir), store3(weight));
        let (wd, sp, sa) = (width.to_array(), spread.to_array(), sample.to_array());
        for i in 0..LANES {
            if bits >> i & 1 != 0 {
                let (k, j) = (self.len / LANES, self.len % LANES);
                let b = &mut self.blocks[k];
                for c in 0..3 {
                    (b.origin[c][j], b.dir[c][j], b.weight[c][j]) = (o[c][i], d[c][i], w[c][i]);
                }
                (b.width[j], b.spread[j], b.sample[j]) = (wd[i], sp[i], sa[i]);
                self.len += 1;
            }
        }
    }

    /// Rays `start..start + 8` (`start` a multiple of 8; the lanes past the end inactive).
    #[inline(always)]
    fn batch<I: Isa>(&self, start: usize) -> (Rays8<I>, Lanes<I>, M8<I>) {
        let b = &self.blocks[start / LANES];
        let rays =
            Rays8 { origin: load3(&b.origin), dir: load3(&b.dir), tmin: F8::zero(), tmax: F8::splat(f32::INFINITY) };
        let lanes = Lanes {
            weight: load3(&b.weight),
            width: F8::from_array(b.width),
            spread: F8::from_array(b.spread),
            sample: U8x::from_array(b.sample),
        };
        (rays, lanes, M8::first(self.len - start))
    }
}

/// Per-sample sums of a tile: the sample's colour (every contribution of its tree) and its
/// first hit (the AOVs).
#[derive(Default)]
pub(super) struct TileSums {
    colour: Vec<Rgb>,
    hit: Vec<bool>,
    normal: Vec<Vec3>,
    albedo: Vec<Rgb>,
    depth: Vec<f32>,
}

impl TileSums {
    fn reset(&mut self, samples: usize) {
        self.colour.clear();
        self.colour.resize(samples, Rgb::ZERO);
        self.hit.clear();
        self.hit.resize(samples, false);
        self.normal.resize(samples, Vec3::ZERO);
        self.albedo.resize(samples, Rgb::ZERO);
        self.depth.resize(samples, 0.0);
    }

    #[inline(always)]
    pub(super) fn add(&mut self, sample: usize, c: Rgb) {
        self.colour[sample] += c;
    }

    #[inline(always)]
    pub(super) fn first_hit(&mut self, sample: usize, normal: Vec3, albedo: Rgb, depth: f32) {
        self.hit[sample] = true;
        self.normal[sample] = normal;
        self.albedo[sample] = albedo;
        self.depth[sample] = depth;
    }
}

/// A thread's reusable state (kept between bands and frames: fresh pages cost more than the
/// tracing they hold).
#[derive(Default)]
pub(super) struct Scratch {
    current: Stream,
    next: Stream,
    sums: TileSums,
}

/// What a frame's bands share.
pub(super) struct Frame<'a> {
    pub shading: Shading<'a>,
    pub rays: CameraRays,
    /// The pinhole image plane the packets are made from ([`CameraRays::image_plane`]).
    pub plane: (Vec3, Vec3, Vec3),
    pub samples: Samples,
    pub samples_per_side: u32,
    pub centre_cone: f32,
    /// The camera's forward axis (unit), for the primary rays' cones.
    pub forward: Vec3,
    pub width: usize,
    pub seed: u64,
    /// The image's place in its film (pixel ids and camera positions are the film's).
    pub image: ImageSettings,
    /// The sphere set seen from the eye, where every primary ray starts.
    pub eye_cones: PointCones,
}

impl<'a> Frame<'a> {
    pub(super) fn new(
        world: &'a World,
        camera: &Camera,
        image: &ImageSettings,
        settings: &WhittedSettings,
        samples: Samples,
    ) -> Self {
        let rays = image.camera_rays(camera);
        let scene = world.scene();
        // `whitted::render` runs the scalar kernel for the other lenses; were one to come
        // here, the packets would be its pinhole's (the lens's centre).
        let pinhole = Camera { lens: glint_scene::Lens::Pinhole, ..*camera };
        let plane = rays.image_plane().unwrap_or_else(|| {
            image.camera_rays(&pinhole).image_plane().unwrap_or((Vec3::ZERO, Vec3::ZERO, Vec3::ZERO))
        });
        Frame {
            plane,
            shading: Shading {
                world,
                materials: MaterialTable::new(&scene.materials),
                lights: scene.lights.iter().map(|l| ShadowLight::new(l, world)).collect(),
                max_depth: settings.max_depth,
                min_contribution: settings.min_contribution,
                eye: rays.origin,
                forward: rays.forward,
            },
            centre_cone: 1.0 / (rays.focal_pixels * settings.samples_per_side as f32),
            rays,
            samples,
            samples_per_side: settings.samples_per_side,
            forward: camera.forward.normalize(),
            width: image.width as usize,
            seed: image.seed,
            image: *image,
            eye_cones: world.point_cones(rays.origin),
        }
    }
}

/// Render one band of rows (band `band_index`, its pixels `band`) tile by tile, with the
/// lanes of `I`. Forced inline: `glint_accel::lanes::dispatch` compiles it, and everything it
/// calls, once per instruction set.
#[inline(always)]
pub(super) fn render_band<I: Isa>(
    frame: &Frame,
    scratch: &mut Scratch,
    band_index: usize,
    rows: usize,
    mut band: FilmRows,
) -> BandStats {
    let mut counts = RayCounts::default();
    let (mut rejected, mut clamped) = (0, 0);
    let y0 = band_index * rows;
    let band_rows = band.len() / frame.width;
    for x0 in (0..frame.width).step_by(TILE_W) {
        let tile_w = TILE_W.min(frame.width - x0);
        let (r, c) = render_tile::<I>(frame, scratch, x0, y0, tile_w, band_rows, &mut counts, &mut band);
        (rejected, clamped) = (rejected + r, clamped + c);
    }
    BandStats { rays: counts, rejected, clamped }
}

/// One tile: primary stream, depth levels, then the pixels. Returns the samples dropped and
/// clamped.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn render_tile<I: Isa>(
    frame: &Frame,
    scratch: &mut Scratch,
    x0: usize,
    y0: usize,
    tile_w: usize,
    tile_h: usize,
    counts: &mut RayCounts,
    band: &mut FilmRows,
) -> (u64, u64) {
    let per_pixel = frame.samples.range(frame.samples_per_side).len();
    let pixels = tile_w * tile_h;
    let Scratch { current, next, sums } = scratch;
    sums.reset(pixels * per_pixel);
    // One sample of every pixel at a time, each to the end of its rays' trees: a sample's
    // streams, and so the order its contributions are added in, are the same whichever other
    // samples the frame traces (a frame split into chunks of samples merges to the same bits).
    for (k, sample) in frame.samples.range(frame.samples_per_side).enumerate() {
        current.clear();
        primary_stream::<I>(frame, x0, y0, tile_w, tile_h, sample, k, current);
        trace_streams::<I>(frame, current, next, sums, counts);
    }
    resolve_tile(frame, sums, x0, tile_w, tile_h, band)
}

/// Trace `current` (a tile's primary rays) and every ray they spawn, depth by depth, adding
/// their contributions to `sums`.
#[inline(always)]
fn trace_streams<I: Isa>(
    frame: &Frame,
    current: &mut Stream,
    next: &mut Stream,
    sums: &mut TileSums,
    counts: &mut RayCounts,
) {
    let s = &frame.shading;
    let sky = s.world.sky();
    let mut depth = 0;
    let mut surf = crate::world::Surfaces8::default();
    while current.len() > 0 {
        next.clear();
        for start in (0..current.len()).step_by(LANES) {
            let (rays, lanes, active) = current.batch::<I>(start);
            let traced = u64::from(active.bits().count_ones());
            if depth == 0 {
                counts.primary += traced;
            } else {
                counts.secondary += traced;
            }
            // Primary rays leave the eye: the eye's cones skip the spheres no lane meets.
            let spheres = if depth == 0 { frame.eye_cones.candidates(rays.dir, active) } else { u64::MAX };
            s.world.intersect_batch_among(&rays, active, spheres, &mut surf);
            let miss = active.and_not(surf.hit);
            if miss.any() {
                let seen = lanes.weight * sky8(sky, rays.dir, lanes.spread, miss);
                for i in 0..LANES {
                    if miss.lane(i) {
                        sums.add(lanes.sample[i] as usize, seen.lane(i));
                    }
                }
            }
            let hit = active & surf.hit;
            if hit.any() {
                counts.shadow += shade(s, &rays, &lanes, &surf, hit, depth, sums, next);
            }
        }
        std::mem::swap(current, next);
        depth += 1;
    }
}

/// The primary rays of a tile: sample s of every pixel, 4 × 2 pixel packets in row-major
/// order; sample s is the frame's k-th, whose entry in the sums for the tile's pixel `p` is
/// `k · pixels + p`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn primary_stream<I: Isa>(
    frame: &Frame,
    x0: usize,
    y0: usize,
    tile_w: usize,
    tile_h: usize,
    s: u32,
    k: usize,
    out: &mut Stream,
) {
    let n = frame.samples_per_side;
    let pixels = tile_w * tile_h;
    let origin = V8::<I>::splat(frame.rays.origin);
    let forward = V8::splat(frame.forward);
    // CameraRays::ray across lanes: the same operations, so the same directions.
    let (top_left, right, down) = frame.plane;
    // Film position of the image's pixel (0, 0) (whole numbers: sums stay exact).
    let (film_x, film_y) = (frame.image.film_origin().0 as f32, frame.image.film_origin().1 as f32);
    let (top_left, right, down) = (V8::splat(top_left), V8::splat(right), V8::splat(down));
    // Pixel centres (one sample, or a pass's first): the same sums across lanes.
    let centred = matches!(frame.samples, Samples::Pass(0))
        || (matches!(frame.samples, Samples::Stratified | Samples::One(_)) && n == 1);
    let (lane_x, lane_y) = (F8::from_fn(|i| (i % 4) as f32), F8::from_fn(|i| (i / 4) as f32));
    let lane_k = U8x::from_array(std::array::from_fn(|i| ((i / 4) * tile_w + i % 4) as u32));
    for by in (0..tile_h).step_by(2) {
        for bx in (0..tile_w).step_by(4) {
            if centred && bx + 4 <= tile_w && by + 2 <= tile_h {
                let (x, y) = ((x0 + bx) as f32, (y0 + by) as f32);
                let half = F8::splat(0.5);
                let px = F8::splat(film_x) + (F8::splat(x) + lane_x) + half;
                let py = F8::splat(film_y) + (F8::splat(y) + lane_y) + half;
                let dir = (top_left + right.scale(px) + down.scale(py)).normalize();
                let cos = dir.dot(forward);
                let spread = F8::splat(frame.centre_cone) * cos * cos.sqrt();
                let sample = U8x::splat((by * tile_w + bx) as u32).wrapping_add(lane_k);
                out.push_lanes(M8::all(), origin, dir, V8::splat1(1.0), F8::zero(), spread, sample);
                continue;
            }
            let mut live = 0u32;
            let (mut px, mut py) = (F8::zero(), F8::zero());
            let mut sample = U8x::splat(0);
            for i in 0..LANES {
                let (tx, ty) = (bx + i % 4, by + i / 4);
                if tx >= tile_w || ty >= tile_h {
                    continue;
                }
                let (x, y) = (x0 + tx, y0 + ty);
                let offset = sample_offset(frame, frame.image.pixel_id(x, y), s);
                (px[i], py[i]) = (film_x + x as f32 + offset.x, film_y + y as f32 + offset.y);
                sample[i] = (k * pixels + ty * tile_w + tx) as u32;
                live |= 1 << i;
            }
            let dir = (top_left + right.scale(px) + down.scale(py)).normalize();
            let cos = dir.dot(forward);
            let spread = F8::splat(frame.centre_cone) * cos * cos.sqrt();
            out.push_lanes(M8::from_bits(live), origin, dir, V8::splat1(1.0), F8::zero(), spread, sample);
        }
    }
}

/// Where sample `s` of pixel `pixel` lies inside it (the scalar driver's patterns).
#[inline(always)]
fn sample_offset(frame: &Frame, pixel: u64, s: u32) -> Vec2 {
    let n = frame.samples_per_side;
    match frame.samples {
        Samples::Stratified | Samples::One(_) if n == 1 => Vec2::splat(0.5),
        Samples::Pass(0) => Vec2::splat(0.5),
        Samples::Stratified | Samples::One(_) => {
            stratified_2d(s, n, SampleStream::new(pixel, u64::from(s), frame.seed).next_2d())
        }
        Samples::Pass(k) => SampleStream::new(pixel, u64::from(k), frame.seed).next_2d(),
    }
}

/// The tile's pixels from its sample sums, as the scalar driver's pixel accumulator makes
/// them. Returns the samples dropped (NaN or infinite colour) and clamped.
fn resolve_tile(
    frame: &Frame,
    sums: &TileSums,
    x0: usize,
    tile_w: usize,
    tile_h: usize,
    band: &mut FilmRows,
) -> (u64, u64) {
    let per_pixel = frame.samples.range(frame.samples_per_side).len();
    let pixels = tile_w * tile_h;
    let (mut rejected, mut clamped) = (0, 0);
    // One sample: its raw record, or the pixel of one sample (the normal normalised).
    let raw = matches!(frame.samples, Samples::One(_));
    if per_pixel == 1 {
        // The real-time case without the loop over samples (which cost 135 instructions a
        // pixel, a tenth of the frame): the same sums from zero, so the same bits.
        for ty in 0..tile_h {
            let k0 = ty * tile_w;
            let at = ty * frame.width + x0;
            let colours = &sums.colour[k0..k0 + tile_w];
            let hits = &sums.hit[k0..k0 + tile_w];
            for ((out, c), hit) in band.pixels[at..][..tile_w].iter_mut().zip(colours).zip(hits) {
                let colour = Rgb::ZERO + admit(*c, &mut rejected, &mut clamped).unwrap_or(Rgb::ZERO);
                *out = FilmPixel { colour, coverage: if *hit { 1.0 } else { 0.0 } };
            }
            // The first-hit AOVs, when the film holds them (not for a PNG's beauty alone).
            let Some(row) = band.surface.get_mut(at..at + tile_w) else { continue };
            let (normals, albedos, depths) =
                (&sums.normal[k0..k0 + tile_w], &sums.albedo[k0..k0 + tile_w], &sums.depth[k0..k0 + tile_w]);
            for (tx, out) in row.iter_mut().enumerate() {
                *out = if hits[tx] {
                    let normal = Vec3::ZERO + normals[tx];
                    SurfacePixel {
                        normal: if raw { normal } else { normal.normalize_or_zero() },
                        albedo: Rgb::ZERO + albedos[tx],
                        depth: 0.0 + depths[tx],
                    }
                } else {
                    SurfacePixel::default()
                };
            }
        }
        return (rejected, clamped);
    }
    // Each sample's record added in sample order, as a frame split into chunks of samples
    // is merged (`SampleSum`).
    let inv_samples = 1.0 / per_pixel as f32;
    for ty in 0..tile_h {
        for tx in 0..tile_w {
            let p = ty * tile_w + tx;
            let mut acc = PixelAccumulator::default();
            for s in 0..per_pixel {
                let k = s * pixels + p;
                let colour = admit(sums.colour[k], &mut rejected, &mut clamped).unwrap_or(Rgb::ZERO);
                let hit = sums.hit[k].then(|| (sums.normal[k], sums.albedo[k], sums.depth[k]));
                acc.add_record(&PixelAccumulator::one(colour, hit).record());
            }
            band.set(ty * frame.width + x0 + tx, acc.finish(inv_samples));
        }
    }
    (rejected, clamped)
}

/// A sample's colour as the pixel takes it: None (counted in `rejected`) when not finite,
/// clamped to [`MAX_SAMPLE_RADIANCE`] (counted in `clamped`) when brighter.
#[inline(always)]
fn admit(c: Rgb, rejected: &mut u64, clamped: &mut u64) -> Option<Rgb> {
    if !c.is_finite() {
        *rejected += 1;
        None
    } else if c.max_element() > MAX_SAMPLE_RADIANCE {
        *clamped += 1;
        Some(c.min(Rgb::splat(MAX_SAMPLE_RADIANCE)))
    } else {
        Some(c)
    }
}
