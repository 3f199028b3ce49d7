//! Chunk files (pipeline: a share of a frame's passes → [`PathSums`] → **chunk file** → merge
//! → the frame): an EXR table ([`glint_image::ExrTable`]) holding a share's per-pixel sums
//! losslessly and, in its header, what the merge checks and needs.
//!
//! Channels: every fixed-point sum ([`crate::fixed`]) as little-endian u32 words,
//! `sum.<quantity>.<R|G|B>.w<k>` (colour, Direct, Indirect: 4 words; Square, without a filter:
//! 6 words), the counts `count.samples` and `count.covered` (u32), and in the chunk holding the
//! frame's first unit, the first sample's AOVs as f32 (`first.Albedo.R/G/B`, `first.Ns.X/Y/Z`,
//! `first.Z`). Header: one text attribute `glint` of `name=value` lines: `glint.format`, `glint.version`, `glint.hash` (of
//! everything that changes the picture, given by the caller), `glint.chunk` (`I/N`),
//! `glint.units` (`first..end/total`), `glint.filtered`, and the caller's `glint.setting.*`
//! (what the merge needs to finish the frame as the single run would: tone map, exposure).
//!
//! [`merge`] checks a set of chunks against each other (one frame, every chunk once) and adds
//! them; every refusal names the files.

use crate::fixed::{self, Square};
use crate::path::{FirstSample, PathSums, PixelSums};
use glint_core::{Rgb, Vec3};
use glint_image::{ExrTable, TableData};
use std::fmt;
use std::path::{Path, PathBuf};

/// What the `glint.format` field says: the layout this module reads and writes.
pub const FORMAT: &str = "glint-chunk 1";
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

/// One chunk: which share of which frame, and its sums.
#[derive(Clone, Debug, PartialEq)]
pub struct Chunk {
    /// The hash of everything that changes the picture (hex; the caller computes it).
    pub hash: String,
    /// The glint version that rendered it.
    pub version: String,
    pub index: u32,
    pub count: u32,
    /// The frame's units this chunk holds, and the frame's total.
    pub first_unit: u64,
    pub end_unit: u64,
    pub total_units: u64,
    /// `glint.setting.<name>` attributes: the caller's settings for finishing the frame.
    pub settings: Vec<(String, String)>,
    pub sums: PathSums,
}

const QUANTITIES: [&str; 3] = ["colour", "Direct", "Indirect"];
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

impl Chunk {
    /// The EXR table of this chunk.
    #[must_use]
    pub fn to_table(&self) -> ExrTable {
        let s = &self.sums;
        // Every plane filled in one pass over the pixels (a pass per plane read the 256-byte
        // pixel sums 50 times: a tenth of a 1024 × 768 chunk's CPU time).
        let mut names = Vec::new();
        for name in QUANTITIES {
            for ch in RGB {
                names.extend((0..4).map(|w| format!("sum.{name}.{ch}.w{w}")));
            }
        }
        if !s.filtered {
            for ch in RGB {
                names.extend((0..6).map(|w| format!("sum.Square.{ch}.w{w}")));
            }
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
            if !s.filtered {
                p.square.iter().flat_map(|sq| sq.words()).for_each(&mut push);
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
        let mut attributes = vec![
            ("glint.format".to_string(), FORMAT.to_string()),
            ("glint.version".into(), self.version.clone()),
            ("glint.hash".into(), self.hash.clone()),
            ("glint.chunk".into(), format!("{}/{}", self.index, self.count)),
            ("glint.units".into(), format!("{}..{}/{}", self.first_unit, self.end_unit, self.total_units)),
            ("glint.filtered".into(), s.filtered.to_string()),
        ];
        attributes.extend(self.settings.iter().map(|(k, v)| (format!("glint.setting.{k}"), v.clone())));
        // One header attribute holds them all, a `name=value` line each: the exr crate keeps
        // attributes in a hash map, whose order (and so the file's bytes) would vary by run.
        let text: String = attributes.iter().map(|(k, v)| format!("{k}={v}\n")).collect();
        ExrTable { width: s.width, height: s.height, channels, attributes: vec![(HEADER.to_string(), text)] }
    }

    /// Write the chunk to `path` (temp file + rename).
    ///
    /// # Errors
    /// [`ChunkError`] naming the file when it cannot be written.
    pub fn write(&self, path: &Path) -> Result<(), ChunkError> {
        glint_image::write_exr_table(path, &self.to_table()).map_err(|e| ChunkError { message: e.to_string() })
    }

    /// Read the chunk at `path`.
    ///
    /// # Errors
    /// [`ChunkError`] naming the file: unreadable, truncated, not an EXR, an EXR that is not a
    /// glint chunk (of this format), or a chunk with a channel missing or of the wrong type.
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
        let chunk = attr("glint.chunk")?;
        let (index, count) = chunk
            .split_once('/')
            .and_then(|(i, n)| Some((i.parse::<u32>().ok()?, n.parse::<u32>().ok()?)))
            .filter(|&(i, n)| i < n)
            .ok_or_else(|| bad("glint.chunk", chunk))?;
        let units = attr("glint.units")?;
        let (first_unit, end_unit, total_units) = units
            .split_once("..")
            .and_then(|(a, rest)| {
                let (b, n) = rest.split_once('/')?;
                Some((a.parse::<u64>().ok()?, b.parse::<u64>().ok()?, n.parse::<u64>().ok()?))
            })
            .filter(|&(a, b, n)| a < b && b <= n)
            .ok_or_else(|| bad("glint.units", units))?;
        let filtered = match attr("glint.filtered")? {
            "true" => true,
            "false" => false,
            v => return Err(bad("glint.filtered", v)),
        };
        let n = t.width as usize * t.height as usize;
        let u32s = |name: &str| match t.channel(name) {
            Some(TableData::U32(v)) if v.len() == n => Ok(v.as_slice()),
            Some(_) => Err(fail(path, format!("channel {name} is not of 32-bit unsigned integers"))),
            None => Err(fail(path, format!("channel {name} is missing"))),
        };
        let mut pixels = vec![PixelSums::default(); n];
        for (q, name) in QUANTITIES.iter().enumerate() {
            for (c, ch) in RGB.iter().enumerate() {
                let w: Vec<&[u32]> =
                    (0..4).map(|w| u32s(&format!("sum.{name}.{ch}.w{w}"))).collect::<Result<_, _>>()?;
                for (i, p) in pixels.iter_mut().enumerate() {
                    sum_of_mut(p, q)[c] = fixed::from_words_i128([w[0][i], w[1][i], w[2][i], w[3][i]]);
                }
            }
        }
        if !filtered {
            for (c, ch) in RGB.iter().enumerate() {
                let w: Vec<&[u32]> =
                    (0..6).map(|w| u32s(&format!("sum.Square.{ch}.w{w}"))).collect::<Result<_, _>>()?;
                for (i, p) in pixels.iter_mut().enumerate() {
                    p.square[c] = Square::from_words([w[0][i], w[1][i], w[2][i], w[3][i], w[4][i], w[5][i]]);
                }
            }
        }
        for (i, (s, c)) in u32s("count.samples")?.iter().zip(u32s("count.covered")?).enumerate() {
            pixels[i].samples = *s;
            pixels[i].covered = *c;
        }
        let first = if first_unit == 0 {
            let planes: Vec<&[f32]> = FIRST
                .iter()
                .map(|name| match t.channel(name) {
                    Some(TableData::F32(v)) if v.len() == n => Ok(v.as_slice()),
                    _ => Err(fail(path, format!("channel {name} is missing or not of 32-bit floats"))),
                })
                .collect::<Result<_, _>>()?;
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
        let settings = fields
            .iter()
            .filter_map(|(k, v)| k.strip_prefix("glint.setting.").map(|k| (k.to_string(), v.clone())))
            .collect();
        Ok(Chunk {
            hash: attr("glint.hash")?.to_string(),
            version: attr("glint.version")?.to_string(),
            index,
            count,
            first_unit,
            end_unit,
            total_units,
            settings,
            sums: PathSums { width: t.width, height: t.height, filtered, units: end_unit - first_unit, pixels, first },
        })
    }
}

/// Check that `chunks` (read from the paths beside them) are every chunk of one frame, each
/// once, and add them in index order: the frame's sums and the chunks' settings.
///
/// # Errors
/// [`ChunkError`] naming the files: no chunks; chunks of another frame (hash, glint version,
/// chunk count, size, units, settings) than the first; two files of one chunk; a missing
/// chunk; units that do not tile the frame.
pub fn merge(chunks: Vec<(PathBuf, Chunk)>) -> Result<(PathSums, Vec<(String, String)>), ChunkError> {
    let Some((first_path, first)) = chunks.first() else {
        return Err(ChunkError { message: "no chunk files to merge".into() });
    };
    let (first_path, first) = (first_path.clone(), first.clone());
    let mut slots: Vec<Option<(PathBuf, Chunk)>> = vec![None; first.count as usize];
    let differs = |path: &Path, what: &str, a: &dyn fmt::Display, b: &dyn fmt::Display| ChunkError {
        message: format!(
            "{} and {} are not chunks of one frame: {what} {a} vs {b}",
            first_path.display(),
            path.display()
        ),
    };
    for (path, c) in chunks {
        if c.hash != first.hash {
            return Err(differs(&path, "scene and settings hash", &first.hash, &c.hash));
        }
        if c.version != first.version {
            return Err(differs(&path, "glint version", &first.version, &c.version));
        }
        if c.count != first.count {
            return Err(differs(&path, "chunk count", &first.count, &c.count));
        }
        let size = |c: &Chunk| format!("{}x{}", c.sums.width, c.sums.height);
        if size(&c) != size(&first) || c.sums.filtered != first.sums.filtered || c.total_units != first.total_units {
            return Err(differs(&path, "frame size and units", &size(&first), &size(&c)));
        }
        if c.settings != first.settings {
            return Err(differs(
                &path,
                "output settings",
                &format!("{:?}", first.settings),
                &format!("{:?}", c.settings),
            ));
        }
        let slot = &mut slots[c.index as usize];
        if let Some((other, _)) = slot {
            return Err(ChunkError {
                message: format!("{} and {} are both chunk {}/{}", other.display(), path.display(), c.index, c.count),
            });
        }
        *slot = Some((path, c));
    }
    let missing: Vec<String> =
        slots.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| i.to_string()).collect();
    if !missing.is_empty() {
        return Err(ChunkError {
            message: format!(
                "chunk{} {} of {} missing (the files given hold the others, e.g. {})",
                if missing.len() == 1 { "" } else { "s" },
                missing.join(", "),
                first.count,
                first_path.display()
            ),
        });
    }
    let mut total: Option<PathSums> = None;
    let mut next_unit = 0;
    for (path, c) in slots.into_iter().flatten() {
        if c.first_unit != next_unit {
            return Err(fail(
                &path,
                format!("holds units {}..{}, expected them to start at {next_unit}", c.first_unit, c.end_unit),
            ));
        }
        next_unit = c.end_unit;
        match &mut total {
            None => total = Some(c.sums),
            Some(t) => t.add(&c.sums).map_err(|e| fail(&path, e))?,
        }
    }
    if next_unit != first.total_units {
        return Err(fail(
            &first_path,
            format!("the chunks hold {next_unit} of the frame's {} units", first.total_units),
        ));
    }
    let sums = total.ok_or_else(|| ChunkError { message: "no chunk files to merge".into() })?;
    Ok((sums, first.settings))
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
        let sums = PathSums { width, height: 2, filtered: false, units: b - a, pixels, first };
        let c = Chunk {
            hash: "ab".repeat(16),
            version: "0.1.0".into(),
            index,
            count,
            first_unit: a,
            end_unit: b,
            total_units: total,
            settings: vec![("exposure".into(), "0.0".into())],
            sums,
        };
        (PathBuf::from(format!("part_{index}.exr")), c)
    }

    #[test]
    fn a_chunk_round_trips_through_its_table() {
        for (index, count) in [(0, 1), (0, 3), (2, 3)] {
            let (path, c) = chunk(index, count, 3);
            assert_eq!(Chunk::from_table(&path, &c.to_table()).expect("read back"), c);
        }
    }

    #[test]
    fn merging_adds_every_chunk_once_and_refuses_the_rest() {
        let all: Vec<_> = (0..3).map(|i| chunk(i, 3, 3)).collect();
        let (sums, _) = merge(all.iter().rev().cloned().collect()).expect("merge");
        assert_eq!(sums.units, 6);
        assert_eq!(sums.pixels[0].samples, 6);
        assert_eq!(sums.pixels[0].covered, 3);
        assert!(sums.first.is_some());
        let refused = |set: Vec<(PathBuf, Chunk)>, needle: &str| {
            let e = merge(set).expect_err("refused").to_string();
            assert!(e.contains(needle), "{e}");
        };
        let mut wide = all.clone();
        wide[1] = chunk(1, 3, 4);
        refused(wide, "frame size");
        let mut other = all.clone();
        other[2].1.settings[0].1 = "1.0".into();
        refused(other, "output settings");
        let mut old = all.clone();
        old[1].1.version = "0.0.9".into();
        refused(old, "glint version");
        let mut gap = all.clone();
        gap[1].1.first_unit = 3;
        refused(gap, "expected them to start at 2");
        refused(Vec::new(), "no chunk files");
        refused(all[..2].to_vec(), "chunk 2 of 3 missing");
    }
}
