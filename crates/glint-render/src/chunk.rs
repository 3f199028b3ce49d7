//! Chunk files (pipeline: a part of a frame — a share of its passes or samples, or a tile of
//! its pixels — → [`Part`] → **chunk file** → merge → the frame): an EXR table
//! ([`glint_image::ExrTable`]) holding a part losslessly and, in its header, what the merge
//! checks and needs.
//!
//! Channels of a path part (its region's pixels): every fixed-point sum ([`crate::fixed`]) as
//! little-endian u32 words, `sum.<quantity>.<R|G|B>.w<k>` (colour, Direct, Indirect: 4 words;
//! Square, without a filter unless splatted: 6 words; the splat's `sum.weight.w<k>`: 4 words),
//! the counts `count.samples` and `count.covered` (u32),
//! and in the chunk holding the frame's first unit, the first sample's AOVs as f32
//! (`first.Albedo.R/G/B`, `first.Ns.X/Y/Z`, `first.Z`). Channels of a Whitted part (f32):
//! `whitted.<R|G|B>`, `whitted.N.<X|Y|Z>`, `whitted.Albedo.<R|G|B>`, `whitted.Z`,
//! `whitted.coverage`: finished pixels (a part holding every sample) or its samples' raw
//! records one below the other (the table is `samples × height` rows).
//!
//! Header: one text attribute `glint` of `name=value` lines: `glint.format`, `glint.version`,
//! `glint.hash` (of everything that changes the picture, given by the caller), `glint.kind`
//! (`path` or `whitted`), `glint.split` (`samples` or `tiles`), `glint.chunk` (`I/N`),
//! `glint.units` (`first..end/total`), `glint.frame` (`WxH`), `glint.region`
//! (`x0,y0,w,h`), `glint.filtered`, `glint.splat` (samples splatted through the pixel
//! filter: [`PathSums::splat`]), and the caller's `glint.setting.*` (what the merge needs
//! to finish the frame as the single run would: tone map, exposure).
//!
//! [`merge`] checks a set of chunks against each other (one frame, every chunk once, the
//! shares or tiles covering it) and puts them together; every refusal names the files.

use crate::film::{Film, PixelRecord};
use crate::fixed::{self, Square};
use crate::frame::{Part, WhittedPart};
use crate::path::{FirstSample, PathSums, PixelSums};
use crate::settings::Region;
use crate::whitted::SampleSum;
use glint_core::{Rgb, Vec3};
use glint_image::{ExrTable, TableData};
use std::fmt;
use std::path::{Path, PathBuf};

/// What the `glint.format` field says: the layout this module reads and writes.
pub const FORMAT: &str = "glint-chunk 3";
/// The header attribute (type string) that holds the fields, one `name=value` line each.
pub const HEADER: &str = "glint";

/// A chunk file could not be written, read or merged: the message names the file(s).
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct ChunkError {
    pub message: String,
}

fn fail(path: &Path, message: impl fmt::Display) -> ChunkError {
    ChunkError { message: format!("{}: {message}", path.display()) }
}

/// How a frame was split into chunks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Each chunk holds a contiguous share of the frame's units over every pixel.
    Samples,
    /// Each chunk holds every unit of one tile ([`Region::tile`]).
    Tiles,
}

impl Split {
    fn name(self) -> &'static str {
        match self {
            Split::Samples => "samples",
            Split::Tiles => "tiles",
        }
    }
}

/// One chunk: which part of which frame, and the part.
#[derive(Clone, Debug, PartialEq)]
pub struct Chunk {
    /// The hash of everything that changes the picture (hex; the caller computes it).
    pub hash: String,
    /// The glint version that rendered it.
    pub version: String,
    pub split: Split,
    pub index: u32,
    pub count: u32,
    /// The frame's units this chunk holds, and the frame's total.
    pub first_unit: u64,
    pub end_unit: u64,
    pub total_units: u64,
    /// The frame's size (the merged picture's).
    pub frame: (u32, u32),
    /// The frame's pixels this chunk holds (all of them for a share of samples).
    pub region: Region,
    /// `glint.setting.<name>` attributes: the caller's settings for finishing the frame.
    pub settings: Vec<(String, String)>,
    pub part: Part,
}

const QUANTITIES: [&str; 3] = ["colour", "Direct", "Indirect"];
const WHITTED: [&str; 11] = [
    "whitted.R",
    "whitted.G",
    "whitted.B",
    "whitted.N.X",
    "whitted.N.Y",
    "whitted.N.Z",
    "whitted.Albedo.R",
    "whitted.Albedo.G",
    "whitted.Albedo.B",
    "whitted.Z",
    "whitted.coverage",
];
const RGB: [&str; 3] = ["R", "G", "B"];
const FIRST: [&str; 7] =
    ["first.Albedo.R", "first.Albedo.G", "first.Albedo.B", "first.Ns.X", "first.Ns.Y", "first.Ns.Z", "first.Z"];

fn sum_of(p: &PixelSums, q: usize) -> &[i128; 3] {
    match q {
        0 => &p.colour,
        1 => &p.direct,
        _ => &p.indirect,
    }
}

fn sum_of_mut(p: &mut PixelSums, q: usize) -> &mut [i128; 3] {
    match q {
        0 => &mut p.colour,
        1 => &mut p.direct,
        _ => &mut p.indirect,
    }
}

fn first_value(f: &FirstSample, k: usize) -> f32 {
    [f.albedo.x, f.albedo.y, f.albedo.z, f.normal.x, f.normal.y, f.normal.z, f.depth][k]
}

fn whitted_values(p: &PixelRecord) -> [f32; 11] {
    let (c, n, a) = (p.colour, p.normal, p.albedo);
    [c.x, c.y, c.z, n.x, n.y, n.z, a.x, a.y, a.z, p.depth, p.coverage]
}

/// Copy `src` (a `region.width`-wide block) into `region` of `dst` (`dst_width` wide).
fn place<T: Copy>(dst: &mut [T], dst_width: usize, region: Region, src: &[T]) {
    let (x0, w) = (region.x0 as usize, region.width as usize);
    for (y, row) in src.chunks_exact(w.max(1)).enumerate() {
        let at = (region.y0 as usize + y) * dst_width + x0;
        dst[at..at + w].copy_from_slice(row);
    }
}

impl Chunk {
    /// The EXR table of this chunk.
    #[must_use]
    pub fn to_table(&self) -> ExrTable {
        let (kind, filtered, splat, (width, height), channels) = match &self.part {
            Part::Path(sums) => ("path", sums.filtered, sums.splat, (sums.width, sums.height), path_channels(sums)),
            Part::Whitted(w) => {
                ("whitted", false, false, (w.width, w.pixels.len() as u32 / w.width.max(1)), whitted_channels(w))
            }
        };
        let r = self.region;
        let mut attributes = vec![
            ("glint.format".to_string(), FORMAT.to_string()),
            ("glint.version".into(), self.version.clone()),
            ("glint.hash".into(), self.hash.clone()),
            ("glint.kind".into(), kind.into()),
            ("glint.split".into(), self.split.name().into()),
            ("glint.chunk".into(), format!("{}/{}", self.index, self.count)),
            ("glint.units".into(), format!("{}..{}/{}", self.first_unit, self.end_unit, self.total_units)),
            ("glint.frame".into(), format!("{}x{}", self.frame.0, self.frame.1)),
            ("glint.region".into(), format!("{},{},{},{}", r.x0, r.y0, r.width, r.height)),
            ("glint.filtered".into(), filtered.to_string()),
            ("glint.splat".into(), splat.to_string()),
        ];
        attributes.extend(self.settings.iter().map(|(k, v)| (format!("glint.setting.{k}"), v.clone())));
        // One header attribute holds them all, a `name=value` line each: the exr crate keeps
        // attributes in a hash map, whose order (and so the file's bytes) would vary by run.
        let text: String = attributes.iter().map(|(k, v)| format!("{k}={v}\n")).collect();
        ExrTable { width, height, channels, attributes: vec![(HEADER.to_string(), text)] }
    }

    /// Write the chunk to `path` (temp file + rename).
    ///
    /// # Errors
    /// [`ChunkError`] naming the file when it cannot be written, or when its path sums lack
    /// the path AOVs (a chunk's are read as holding them: [`Renderer::render_part`]'s do).
    ///
    /// [`Renderer::render_part`]: crate::Renderer::render_part
    pub fn write(&self, path: &Path) -> Result<(), ChunkError> {
        if let Part::Path(sums) = &self.part
            && !sums.aovs
        {
            return Err(fail(path, "its path sums were traced without the path AOVs' (a chunk carries them all)"));
        }
        glint_image::write_exr_table(path, &self.to_table()).map_err(|e| ChunkError { message: e.to_string() })
    }

    /// Read the chunk at `path`.
    ///
    /// # Errors
    /// [`ChunkError`] naming the file: unreadable, truncated, not an EXR, an EXR that is not a
    /// glint chunk (of this format), or a chunk whose header does not agree with itself or its
    /// channels (one missing or of the wrong type or size).
    pub fn read(path: &Path) -> Result<Chunk, ChunkError> {
        let table = glint_image::read_exr_table(path).map_err(|e| ChunkError { message: e.to_string() })?;
        Self::from_table(path, &table)
    }

    fn from_table(path: &Path, t: &ExrTable) -> Result<Chunk, ChunkError> {
        let fields: Vec<(String, String)> = t
            .attribute(HEADER)
            .unwrap_or("")
            .lines()
            .filter_map(|l| l.split_once('=').map(|(k, v)| (k.to_string(), v.to_string())))
            .collect();
        let field = |name: &str| fields.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str());
        match field("glint.format") {
            Some(FORMAT) => {}
            Some(other) => return Err(fail(path, format!("a chunk of format {other:?}; this glint reads {FORMAT:?}"))),
            None => return Err(fail(path, "not a glint chunk file (an EXR without glint's chunk header)")),
        }
        let attr = |name: &str| field(name).ok_or_else(|| fail(path, format!("the header has no {name}")));
        let bad = |name: &str, v: &str| fail(path, format!("the header's {name} {v:?} cannot be read"));
        let numbers = |name: &str, sep: char, n: usize| -> Result<Vec<u32>, ChunkError> {
            let v = attr(name)?;
            let parsed: Option<Vec<u32>> = v.split(sep).map(|x| x.parse().ok()).collect();
            parsed.filter(|p| p.len() == n).ok_or_else(|| bad(name, v))
        };
        let chunk = numbers("glint.chunk", '/', 2)?;
        let (index, count) = (chunk[0], chunk[1]);
        if index >= count {
            return Err(bad("glint.chunk", attr("glint.chunk")?));
        }
        let units = attr("glint.units")?;
        let (first_unit, end_unit, total_units) = units
            .split_once("..")
            .and_then(|(a, rest)| {
                let (b, n) = rest.split_once('/')?;
                Some((a.parse::<u64>().ok()?, b.parse::<u64>().ok()?, n.parse::<u64>().ok()?))
            })
            .filter(|&(a, b, n)| a < b && b <= n)
            .ok_or_else(|| bad("glint.units", units))?;
        let flag = |name: &str| match attr(name)? {
            "true" => Ok(true),
            "false" => Ok(false),
            v => Err(bad(name, v)),
        };
        let (filtered, splat) = (flag("glint.filtered")?, flag("glint.splat")?);
        let split = match attr("glint.split")? {
            "samples" => Split::Samples,
            "tiles" => Split::Tiles,
            v => return Err(bad("glint.split", v)),
        };
        let frame = numbers("glint.frame", 'x', 2)?;
        let frame = (frame[0], frame[1]);
        let r = numbers("glint.region", ',', 4)?;
        let region = Region { x0: r[0], y0: r[1], width: r[2], height: r[3] };
        let inside = |at: u32, len: u32, side: u32| len > 0 && u64::from(at) + u64::from(len) <= u64::from(side);
        if !inside(region.x0, region.width, frame.0) || !inside(region.y0, region.height, frame.1) {
            return Err(fail(path, format!("the region {r:?} is not inside the {}x{} frame", frame.0, frame.1)));
        }
        // A Whitted part of some of the samples holds their records, one below the other.
        let raw = end_unit - first_unit < total_units;
        // What the split puts where: a share of samples holds the whole frame, a tile its
        // place in the grid.
        let expected = match split {
            Split::Samples => Region::whole(frame.0, frame.1),
            Split::Tiles => Region::tile(frame.0, frame.1, index, count).map_err(|e| fail(path, e))?,
        };
        if region != expected {
            return Err(fail(
                path,
                format!(
                    "holds the pixels {region:?} of its {}x{} frame, where the {} split puts {expected:?}",
                    frame.0,
                    frame.1,
                    split.name()
                ),
            ));
        }
        let rows = match attr("glint.kind")? {
            "whitted" if raw => u64::from(region.height) * (end_unit - first_unit),
            "whitted" | "path" => u64::from(region.height),
            v => return Err(bad("glint.kind", v)),
        };
        if (u64::from(t.width), u64::from(t.height)) != (u64::from(region.width), rows) {
            return Err(fail(
                path,
                format!("its table is {}x{}, where the header says {}x{rows}", t.width, t.height, region.width),
            ));
        }
        let part = match attr("glint.kind")? {
            "path" => Part::Path(read_path(path, t, (filtered, splat), first_unit == 0, end_unit - first_unit)?),
            _ => Part::Whitted(read_whitted(path, t, region.height, raw)?),
        };
        let settings = fields
            .iter()
            .filter_map(|(k, v)| k.strip_prefix("glint.setting.").map(|k| (k.to_string(), v.clone())))
            .collect();
        Ok(Chunk {
            hash: attr("glint.hash")?.to_string(),
            version: attr("glint.version")?.to_string(),
            split,
            index,
            count,
            first_unit,
            end_unit,
            total_units,
            frame,
            region,
            settings,
            part,
        })
    }
}

/// The channels of a path part.
fn path_channels(s: &PathSums) -> Vec<(String, TableData)> {
    // Every plane filled in one pass over the pixels (a pass per plane read the 256-byte
    // pixel sums 50 times: a tenth of a 1024 × 768 chunk's CPU time).
    let mut names = Vec::new();
    for name in QUANTITIES {
        for ch in RGB {
            names.extend((0..4).map(|w| format!("sum.{name}.{ch}.w{w}")));
        }
    }
    let squares = !s.filtered && !s.splat;
    if squares {
        for ch in RGB {
            names.extend((0..6).map(|w| format!("sum.Square.{ch}.w{w}")));
        }
    }
    if s.splat {
        names.extend((0..4).map(|w| format!("sum.weight.w{w}")));
    }
    names.extend(["count.samples".to_string(), "count.covered".to_string()]);
    let mut planes: Vec<Vec<u32>> = names.iter().map(|_| Vec::with_capacity(s.pixels.len())).collect();
    for p in &s.pixels {
        let mut k = 0;
        let mut push = |w: u32| {
            planes[k].push(w);
            k += 1;
        };
        for q in 0..QUANTITIES.len() {
            sum_of(p, q).iter().flat_map(|&v| fixed::words_i128(v)).for_each(&mut push);
        }
        if squares {
            p.square.iter().flat_map(|sq| sq.words()).for_each(&mut push);
        }
        if s.splat {
            fixed::words_i128(p.weight).into_iter().for_each(&mut push);
        }
        push(p.samples);
        push(p.covered);
    }
    let mut channels: Vec<(String, TableData)> =
        names.into_iter().zip(planes).map(|(name, plane)| (name, TableData::U32(plane))).collect();
    if let Some(first) = &s.first {
        for (k, name) in FIRST.iter().enumerate() {
            channels.push(((*name).into(), TableData::F32(first.iter().map(|f| first_value(f, k)).collect())));
        }
    }
    channels
}

/// The channels of a Whitted part.
fn whitted_channels(w: &WhittedPart) -> Vec<(String, TableData)> {
    let mut planes: Vec<Vec<f32>> = WHITTED.iter().map(|_| Vec::with_capacity(w.pixels.len())).collect();
    for p in &w.pixels {
        for (plane, v) in planes.iter_mut().zip(whitted_values(p)) {
            plane.push(v);
        }
    }
    WHITTED.iter().zip(planes).map(|(name, plane)| ((*name).to_string(), TableData::F32(plane))).collect()
}

/// The path part of table `t` (its size checked against the header), `filtered` and `splat`
/// as the header says.
fn read_path(
    path: &Path,
    t: &ExrTable,
    (filtered, splat): (bool, bool),
    first: bool,
    units: u64,
) -> Result<PathSums, ChunkError> {
    let n = t.width as usize * t.height as usize;
    let u32s = |name: &str| match t.channel(name) {
        Some(TableData::U32(v)) if v.len() == n => Ok(v.as_slice()),
        Some(_) => Err(fail(path, format!("channel {name} is not of 32-bit unsigned integers"))),
        None => Err(fail(path, format!("channel {name} is missing"))),
    };
    let mut pixels = vec![PixelSums::default(); n];
    for (q, name) in QUANTITIES.iter().enumerate() {
        for (c, ch) in RGB.iter().enumerate() {
            let w: Vec<&[u32]> = (0..4).map(|w| u32s(&format!("sum.{name}.{ch}.w{w}"))).collect::<Result<_, _>>()?;
            for (i, p) in pixels.iter_mut().enumerate() {
                sum_of_mut(p, q)[c] = fixed::from_words_i128([w[0][i], w[1][i], w[2][i], w[3][i]]);
            }
        }
    }
    if !filtered && !splat {
        for (c, ch) in RGB.iter().enumerate() {
            let w: Vec<&[u32]> = (0..6).map(|w| u32s(&format!("sum.Square.{ch}.w{w}"))).collect::<Result<_, _>>()?;
            for (i, p) in pixels.iter_mut().enumerate() {
                p.square[c] = Square::from_words([w[0][i], w[1][i], w[2][i], w[3][i], w[4][i], w[5][i]]);
            }
        }
    }
    if splat {
        let w: Vec<&[u32]> = (0..4).map(|w| u32s(&format!("sum.weight.w{w}"))).collect::<Result<_, _>>()?;
        for (i, p) in pixels.iter_mut().enumerate() {
            p.weight = fixed::from_words_i128([w[0][i], w[1][i], w[2][i], w[3][i]]);
        }
    }
    for (i, (s, c)) in u32s("count.samples")?.iter().zip(u32s("count.covered")?).enumerate() {
        pixels[i].samples = *s;
        pixels[i].covered = *c;
    }
    let first = if first {
        let planes = f32_planes(path, t, &FIRST)?;
        Some(
            (0..n)
                .map(|i| FirstSample {
                    albedo: Rgb::new(planes[0][i], planes[1][i], planes[2][i]),
                    normal: Vec3::new(planes[3][i], planes[4][i], planes[5][i]),
                    depth: planes[6][i],
                })
                .collect(),
        )
    } else {
        None
    };
    // Chunks are traced with every AOV (`Renderer::render_part`).
    Ok(PathSums { width: t.width, height: t.height, filtered, splat, aovs: true, units, pixels, first })
}

/// The Whitted part of table `t` (of records `height` rows each).
fn read_whitted(path: &Path, t: &ExrTable, height: u32, raw: bool) -> Result<WhittedPart, ChunkError> {
    let planes = f32_planes(path, t, &WHITTED)?;
    let pixels = (0..t.width as usize * t.height as usize)
        .map(|i| {
            let v = |k: usize| planes[k][i];
            PixelRecord {
                colour: Rgb::new(v(0), v(1), v(2)),
                normal: Vec3::new(v(3), v(4), v(5)),
                albedo: Rgb::new(v(6), v(7), v(8)),
                depth: v(9),
                coverage: v(10),
            }
        })
        .collect();
    Ok(WhittedPart { width: t.width, height, pixels, raw })
}

/// The f32 channels `names` of table `t`, each of its size.
fn f32_planes<'t>(path: &Path, t: &'t ExrTable, names: &[&str]) -> Result<Vec<&'t [f32]>, ChunkError> {
    let n = t.width as usize * t.height as usize;
    names
        .iter()
        .map(|name| match t.channel(name) {
            Some(TableData::F32(v)) if v.len() == n => Ok(v.as_slice()),
            _ => Err(fail(path, format!("channel {name} is missing or not of 32-bit floats"))),
        })
        .collect()
}

/// A frame put together from its chunks.
#[derive(Debug)]
pub struct Merged {
    /// The frame as the single-process render leaves it.
    pub film: Film,
    /// The chunks' `glint.setting.*` (how to write it).
    pub settings: Vec<(String, String)>,
    /// What was merged, for the summary line ("4 tiles of a 640x480 path frame (16 passes)").
    pub description: String,
}

/// Where a chunk read by [`merge`] was and what it held, once its part has been taken in.
struct Seen {
    path: PathBuf,
    first_unit: u64,
    end_unit: u64,
}

/// What the chunks read so far add up to.
enum Sum {
    /// Path sums: shares added (integers: in any order), tiles placed.
    Path(Option<PathSums>),
    /// Whitted: finished pixels placed (tiles, or a whole frame; made at the first), the
    /// records of shares of the samples kept by chunk index (they are added in sample order at
    /// the end).
    Whitted { pixels: Option<Vec<PixelRecord>>, records: Vec<Option<Vec<PixelRecord>>> },
}

/// Check that `chunks` (read one after another from the paths beside them) are every chunk of
/// one frame, each once, and put them together: shares of units added, tiles placed. Each
/// chunk is taken in as it is read (a Whitted share of samples is kept until all are read: its
/// records are added in sample order), so a merge holds about one chunk besides the frame.
///
/// # Errors
/// [`ChunkError`] naming the files: one that cannot be read; no chunks; chunks of another
/// frame (hash, glint version, kind, split, chunk count, size, units, settings) than the
/// first; two files of one chunk; a missing chunk; shares whose units do not tile the
/// frame's, tiles not where the split puts them.
pub fn merge(chunks: impl IntoIterator<Item = Result<(PathBuf, Chunk), ChunkError>>) -> Result<Merged, ChunkError> {
    let mut chunks = chunks.into_iter();
    let (first_path, mut first) = match chunks.next() {
        Some(c) => c?,
        None => return Err(ChunkError { message: "no chunk files to merge".into() }),
    };
    let kind = |c: &Chunk| match &c.part {
        Part::Path(s) if s.filtered => "filtered path",
        Part::Path(s) if s.splat => "splatted path",
        Part::Path(_) => "path",
        Part::Whitted(_) => "whitted",
    };
    let size = |c: &Chunk| format!("{}x{}", c.frame.0, c.frame.1);
    let (w, h) = first.frame;
    let whole = Region::whole(w, h);
    let units_name = match &first.part {
        Part::Path(s) if s.filtered => "passes",
        _ => "samples per pixel",
    };
    let description = format!(
        "{} {} of a {w}x{h} {} frame ({} {units_name})",
        first.count,
        match (first.split, first.count) {
            (Split::Samples, 1) => "chunk",
            (Split::Samples, _) => "chunks of samples",
            (Split::Tiles, 1) => "tile",
            (Split::Tiles, _) => "tiles",
        },
        kind(&first),
        first.total_units
    );
    let (first_kind, first_size) = (kind(&first), size(&first));
    let mut slots: Vec<Option<Seen>> = Vec::new();
    slots.resize_with(first.count as usize, || None);
    let mut sum = match first.part {
        Part::Path(_) => Sum::Path(None),
        Part::Whitted(_) => Sum::Whitted { pixels: None, records: vec![None; first.count as usize] },
    };
    let settings = first.settings.clone();
    // The first chunk is checked (against itself) and taken in like the others: its header is
    // kept (with an empty part) to check the others against.
    let placeholder = Part::Path(PathSums {
        width: 0,
        height: 0,
        filtered: false,
        splat: false,
        aovs: true,
        units: 0,
        pixels: Vec::new(),
        first: None,
    });
    let first_part = std::mem::replace(&mut first.part, placeholder);
    let header = first;
    let mut next = Some((first_path.clone(), Chunk { part: first_part, ..header.clone() }));
    while let Some((path, c)) = next.take() {
        let differs = |what: &str, a: &dyn fmt::Display, b: &dyn fmt::Display| ChunkError {
            message: format!(
                "{} and {} are not chunks of one frame: {what} {a} vs {b}",
                first_path.display(),
                path.display()
            ),
        };
        if c.hash != header.hash {
            return Err(differs("scene and settings hash", &header.hash, &c.hash));
        }
        if c.version != header.version {
            return Err(differs("glint version", &header.version, &c.version));
        }
        if c.split != header.split {
            return Err(differs("split into", &header.split.name(), &c.split.name()));
        }
        if c.count != header.count {
            return Err(differs("chunk count", &header.count, &c.count));
        }
        if kind(&c) != first_kind {
            return Err(differs("kind of frame", &first_kind, &kind(&c)));
        }
        if size(&c) != first_size || c.total_units != header.total_units {
            return Err(differs("frame size and units", &first_size, &size(&c)));
        }
        if c.settings != settings {
            return Err(differs("output settings", &format!("{settings:?}"), &format!("{:?}", c.settings)));
        }
        if let Some(other) = &slots[c.index as usize] {
            return Err(ChunkError {
                message: format!(
                    "{} and {} are both chunk {}/{}",
                    other.path.display(),
                    path.display(),
                    c.index,
                    c.count
                ),
            });
        }
        let region = match c.split {
            Split::Samples => whole,
            Split::Tiles => Region::tile(w, h, c.index, c.count).map_err(|e| fail(&path, e))?,
        };
        if c.region != region {
            return Err(fail(
                &path,
                format!("holds the pixels {:?}, where the {} split puts {region:?}", c.region, c.split.name()),
            ));
        }
        let seen = Seen { path, first_unit: c.first_unit, end_unit: c.end_unit };
        let index = c.index as usize;
        take_in(&mut sum, &seen.path, c, whole)?;
        slots[index] = Some(seen);
        next = chunks.next().transpose()?;
    }
    let missing: Vec<String> =
        slots.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| i.to_string()).collect();
    if !missing.is_empty() {
        return Err(ChunkError {
            message: format!(
                "chunk{} {} of {} missing (the files given hold the others, e.g. {})",
                if missing.len() == 1 { "" } else { "s" },
                missing.join(", "),
                header.count,
                first_path.display()
            ),
        });
    }
    // Shares follow each other in index order; tiles hold every unit.
    let mut next_unit = 0;
    for seen in slots.iter().flatten() {
        let units = match header.split {
            Split::Samples => next_unit..seen.end_unit,
            Split::Tiles => 0..header.total_units,
        };
        if seen.first_unit != units.start || seen.end_unit != units.end {
            return Err(fail(
                &seen.path,
                format!("holds units {}..{}, expected {}..{}", seen.first_unit, seen.end_unit, units.start, units.end),
            ));
        }
        next_unit = seen.end_unit;
    }
    if next_unit != header.total_units {
        return Err(fail(
            &first_path,
            format!("the chunks hold {next_unit} of the frame's {} units", header.total_units),
        ));
    }
    let mut film = Film::try_new(1, 1).map_err(|e| fail(&first_path, e))?;
    match sum {
        Sum::Path(sums) => {
            let sums = sums.ok_or_else(|| ChunkError { message: "no chunk files to merge".into() })?;
            sums.resolve(&mut film).map_err(|e| fail(&first_path, e))?;
        }
        Sum::Whitted { pixels, records } => {
            film.reset(w, h).map_err(|e| fail(&first_path, e))?;
            if let Some(pixels) = pixels {
                let mut rows = film.rows_mut();
                for (i, p) in pixels.into_iter().enumerate() {
                    rows.set(i, p);
                }
            }
            if records.iter().any(Option::is_some) {
                let mut samples = SampleSum::try_new(whole.pixels()).map_err(|e| fail(&first_path, e))?;
                for one in records.iter().flatten().flat_map(|r| r.chunks_exact(whole.pixels().max(1))) {
                    samples.add(one);
                }
                samples.finish(header.total_units as u32, film.rows_mut());
            }
        }
    }
    Ok(Merged { film, settings, description })
}

/// A buffer of the whole frame's pixels, refused (naming the chunk that asked for it) when it
/// does not fit the memory budget: a tile's header names a frame that may be far larger than
/// the tile.
fn frame_buffer<T: Clone>(path: &Path, whole: Region, value: T) -> Result<Vec<T>, ChunkError> {
    let what = || format!("the merged {}x{} frame", whole.width, whole.height);
    let mut v = glint_core::memory::try_with_capacity(what, whole.pixels()).map_err(|e| fail(path, e))?;
    v.resize(whole.pixels(), value);
    Ok(v)
}

/// Take chunk `c`'s part (checked against the frame by [`merge`]) into `sum`.
fn take_in(sum: &mut Sum, path: &Path, c: Chunk, whole: Region) -> Result<(), ChunkError> {
    let width = whole.width as usize;
    match (sum, c.part) {
        (Sum::Path(total), Part::Path(sums)) => {
            if (sums.width, sums.height) != (c.region.width, c.region.height) {
                return Err(fail(path, "its sums are not of its region's size"));
            }
            match (total, c.split) {
                (total @ None, Split::Samples) => *total = Some(sums),
                (Some(t), Split::Samples) => t.add(&sums).map_err(|e| fail(path, e))?,
                (t, Split::Tiles) => {
                    if t.is_none() {
                        *t = Some(PathSums {
                            width: whole.width,
                            height: whole.height,
                            filtered: sums.filtered,
                            splat: sums.splat,
                            aovs: sums.aovs,
                            units: sums.units,
                            pixels: frame_buffer(path, whole, PixelSums::default())?,
                            first: Some(frame_buffer(path, whole, FirstSample::default())?),
                        });
                    }
                    let Some(t) = t.as_mut() else { return Ok(()) };
                    place(&mut t.pixels, width, c.region, &sums.pixels);
                    let (Some(all), Some(part)) = (t.first.as_mut(), sums.first.as_ref()) else {
                        return Err(fail(path, "a tile without its first sample's AOVs"));
                    };
                    place(all, width, c.region, part);
                }
            }
        }
        (Sum::Whitted { pixels, records }, Part::Whitted(part)) => {
            let count = if part.raw { c.end_unit - c.first_unit } else { 1 };
            if part.width != c.region.width || part.pixels.len() as u64 != c.region.pixels() as u64 * count {
                return Err(fail(path, "its pixels are not of its region's size"));
            }
            if part.raw {
                records[c.index as usize] = Some(part.pixels);
            } else {
                if pixels.is_none() {
                    *pixels = Some(frame_buffer(path, whole, PixelRecord::default())?);
                }
                if let Some(pixels) = pixels.as_mut() {
                    place(pixels, width, c.region, &part.pixels);
                }
            }
        }
        _ => return Err(fail(path, "a chunk of another kind of frame")),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chunk(index: u32, count: u32, width: u32) -> (PathBuf, Chunk) {
        let total = 6;
        let (a, b) = ((total * u64::from(index)) / u64::from(count), (total * u64::from(index + 1)) / u64::from(count));
        let mut pixels = vec![PixelSums::default(); width as usize * 2];
        for (i, p) in pixels.iter_mut().enumerate() {
            p.colour = [fixed::quantise(0.25 * (i as f32 + 1.0) * (index + 1) as f32); 3];
            p.square[1].add_square(3.0 + index as f32);
            p.samples = (b - a) as u32;
            p.covered = index;
        }
        let first = (a == 0).then(|| vec![FirstSample { depth: 2.5, ..FirstSample::default() }; width as usize * 2]);
        let sums =
            PathSums { width, height: 2, filtered: false, splat: false, aovs: true, units: b - a, pixels, first };
        let c = Chunk {
            hash: "ab".repeat(16),
            version: "0.1.0".into(),
            split: Split::Samples,
            index,
            count,
            first_unit: a,
            end_unit: b,
            total_units: total,
            frame: (width, 2),
            region: Region::whole(width, 2),
            settings: vec![("exposure".into(), "0.0".into())],
            part: Part::Path(sums),
        };
        (PathBuf::from(format!("part_{index}.exr")), c)
    }

    #[test]
    fn a_chunk_round_trips_through_its_table() {
        for (index, count) in [(0, 1), (0, 3), (2, 3)] {
            let (path, c) = chunk(index, count, 3);
            assert_eq!(Chunk::from_table(&path, &c.to_table()).expect("read back"), c);
            // Splatted: the weights travel, the squares (not kept) do not.
            let (path, mut c) = chunk(index, count, 3);
            let Part::Path(sums) = &mut c.part else { unreachable!() };
            sums.splat = true;
            for (i, p) in sums.pixels.iter_mut().enumerate() {
                p.square = Default::default();
                p.weight = fixed::quantise(0.75 + i as f32) + (1 << 100);
            }
            let table = c.to_table();
            assert!(table.channels.iter().all(|(name, _)| !name.starts_with("sum.Square")));
            assert_eq!(Chunk::from_table(&path, &table).expect("read back"), c);
        }
    }

    #[test]
    fn sums_without_the_path_aovs_are_not_written_as_a_chunk() {
        let dir = std::env::temp_dir().join(format!("glint-chunk-aovs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let (_, mut c) = chunk(0, 1, 3);
        let Part::Path(sums) = &mut c.part else { unreachable!() };
        sums.aovs = false;
        let out = dir.join("part.exr");
        let e = c.write(&out).expect_err("refused");
        assert!(e.message.contains("part.exr") && e.message.contains("without the path AOVs"), "{}", e.message);
        assert!(!out.exists());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn headers_that_disagree_with_themselves_or_the_table_are_refused() {
        let (path, c) = chunk(0, 3, 3);
        let table = c.to_table();
        assert!(Chunk::from_table(&path, &table).is_ok());
        for (from, to, needle) in [
            ("glint.region=0,0,3,2", "glint.region=1,0,3,2", "not inside the 3x2 frame"),
            ("glint.region=0,0,3,2", "glint.region=0,0,2,1", "where the samples split puts"),
            ("glint.split=samples", "glint.split=tiles", "where the tiles split puts"),
            ("glint.region=0,0,3,2", "glint.region=0,0,2,2", "where the samples split puts"),
            ("glint.region=0,0,3,2", "glint.region=0,0,0,2", "not inside"),
            ("glint.region=0,0,3,2", "glint.region=0,0,3,-2", "glint.region"),
            ("glint.kind=path", "glint.kind=points", "glint.kind"),
            ("glint.split=samples", "glint.split=rows", "glint.split"),
            ("glint.frame=3x2", "glint.frame=3", "glint.frame"),
            ("glint.frame=3x2", "glint.frame=4294967295x2", "where the samples split puts"),
            ("glint.chunk=0/3", "glint.chunk=3/3", "glint.chunk"),
            ("glint.units=0..2/6", "glint.units=2..2/6", "glint.units"),
            ("glint.filtered=false", "glint.filtered=maybe", "glint.filtered"),
            ("glint.splat=false", "glint.splat=1", "glint.splat"),
            ("glint.splat=false\n", "", "no glint.splat"),
            ("glint.format=glint-chunk 3", "glint.format=glint-chunk 2", "format"),
        ] {
            let mut t = table.clone();
            t.attributes[0].1 = t.attributes[0].1.replace(from, to);
            let e = Chunk::from_table(&path, &t).expect_err(to).to_string();
            assert!(e.contains(needle) && e.contains("part_0.exr"), "{to}: {e}");
        }
        // A table of another size than the header's region.
        let mut t = table.clone();
        t.height = 1;
        let e = Chunk::from_table(&path, &t).expect_err("table size").to_string();
        assert!(e.contains("its table is 3x1, where the header says 3x2"), "{e}");
        // A splatted header over an unsplatted table: its weights are not there.
        let mut t = table.clone();
        t.attributes[0].1 = t.attributes[0].1.replace("glint.splat=false", "glint.splat=true");
        let e = Chunk::from_table(&path, &t).expect_err("splat").to_string();
        assert!(e.contains("channel sum.weight.w0 is missing") && e.contains("part_0.exr"), "{e}");
        // A Whitted header over a path table: of some samples, its records would be taller;
        // of all of them, its channels are not there.
        let mut t = table.clone();
        t.attributes[0].1 = t.attributes[0].1.replace("glint.kind=path", "glint.kind=whitted");
        let e = Chunk::from_table(&path, &t).expect_err("whitted share").to_string();
        assert!(e.contains("its table is 3x2, where the header says 3x4"), "{e}");
        let (path, whole) = chunk(0, 1, 3);
        let mut t = whole.to_table();
        t.attributes[0].1 = t.attributes[0].1.replace("glint.kind=path", "glint.kind=whitted");
        let e = Chunk::from_table(&path, &t).expect_err("whitted").to_string();
        assert!(e.contains("channel whitted.R is missing"), "{e}");
    }

    #[test]
    fn whitted_parts_round_trip_through_their_tables() {
        let pixel = |i: usize| PixelRecord {
            colour: Rgb::new(i as f32, 0.5, -0.0),
            normal: Vec3::new(0.1, 0.2, i as f32),
            albedo: Rgb::splat(0.25),
            depth: if i.is_multiple_of(2) { f32::INFINITY } else { 3.0 },
            coverage: (i % 2) as f32,
        };
        // Samples 1..3 of 4 (raw records, two below each other), then a whole tile.
        for (first, end, raw, tile) in [(1, 3, true, None), (2, 3, true, None), (0, 4, false, Some((2, 3)))] {
            let region = match tile {
                Some((i, n)) => Region::tile(5, 4, i, n).expect("tile"),
                None => Region::whole(5, 4),
            };
            let records = if raw { (end - first) as usize } else { 1 };
            let part = WhittedPart {
                width: region.width,
                height: region.height,
                pixels: (0..region.pixels() * records).map(pixel).collect(),
                raw,
            };
            let c = Chunk {
                hash: "cd".repeat(16),
                version: "0.1.0".into(),
                split: if tile.is_some() { Split::Tiles } else { Split::Samples },
                index: tile.map_or(1, |t| t.0),
                count: tile.map_or(2, |t| t.1),
                first_unit: first,
                end_unit: end,
                total_units: 4,
                frame: (5, 4),
                region,
                settings: Vec::new(),
                part: Part::Whitted(part),
            };
            let back = Chunk::from_table(Path::new("w.exr"), &c.to_table()).expect("read back");
            assert_eq!(format!("{back:?}"), format!("{c:?}"), "bit for bit (-0 and inf kept)");
        }
    }

    #[test]
    fn tiles_cover_the_image_once_as_square_as_the_count_allows() {
        for (w, h, n) in [(1024, 768, 4), (1024, 768, 7), (640, 480, 6), (3, 5, 15), (100, 1, 7)] {
            let mut seen = vec![0u8; w as usize * h as usize];
            for i in 0..n {
                let r = Region::tile(w, h, i, n).expect("tile");
                assert!(r.width > 0 && r.height > 0);
                for y in r.y0..r.y0 + r.height {
                    for x in r.x0..r.x0 + r.width {
                        seen[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{w}x{h} in {n} tiles");
        }
        assert_eq!(Region::tile(1024, 768, 1, 4).expect("tile"), Region { x0: 512, y0: 0, width: 512, height: 384 });
        assert!(Region::tile(2, 2, 0, 5).is_err(), "5 tiles of 2x2: a grid of 5 does not fit");
        assert!(Region::tile(8, 8, 4, 4).is_err());
    }

    #[test]
    fn merging_adds_every_chunk_once_and_refuses_the_rest() {
        let all: Vec<_> = (0..3).map(|i| chunk(i, 3, 3)).collect();
        let merged = merge(all.iter().rev().cloned().map(Ok)).expect("merge");
        let p = merged.film.record(0);
        assert_eq!(merged.film.path[0].samples, 6.0);
        assert_eq!(p.coverage, 0.5);
        assert_eq!(p.depth, 2.5, "the first sample's AOVs");
        let refused = |set: Vec<(PathBuf, Chunk)>, needle: &str| {
            let e = merge(set.into_iter().map(Ok)).expect_err("refused").to_string();
            assert!(e.contains(needle), "{e}");
        };
        let mut wide = all.clone();
        wide[1] = chunk(1, 3, 4);
        refused(wide, "frame size");
        let mut tiled = all.clone();
        tiled[2].1.split = Split::Tiles;
        refused(tiled, "split into samples vs tiles");
        let mut moved = all.clone();
        moved[1].1.region = Region { x0: 1, y0: 0, width: 2, height: 2 };
        refused(moved, "holds the pixels");
        let mut other = all.clone();
        other[2].1.settings[0].1 = "1.0".into();
        refused(other, "output settings");
        let mut old = all.clone();
        old[1].1.version = "0.0.9".into();
        refused(old, "glint version");
        let mut gap = all.clone();
        gap[1].1.first_unit = 3;
        refused(gap, "holds units 3..4, expected 2..4");
        let mut splatted = all.clone();
        if let Part::Path(sums) = &mut splatted[1].1.part {
            sums.splat = true;
        }
        refused(splatted, "kind of frame path vs splatted path");
        refused(Vec::new(), "no chunk files");
        refused(all[..2].to_vec(), "chunk 2 of 3 missing");
    }
}
