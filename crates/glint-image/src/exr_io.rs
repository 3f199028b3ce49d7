//! OpenEXR in and out, through the `exr` crate, keeping every channel by name.
//!
//! Written files are reproducible: one scan-line layer, 32-bit float channels (sorted by name,
//! as the format requires), increasing-Y line order, lossless PIZ compression (wavelet and
//! Huffman, 32 lines per block), and no timestamp, software or other varying attribute — the
//! same image always gives the same bytes. PIZ over ZIP: on 1080p renders with their AOVs it
//! wrote the file in 0.1–0.5 s less (deflate was most of the time) and made it 6–15 % smaller,
//! 2 % larger on a noisy path-traced Cornell box (BENCHMARKS.md §13.1).

use std::io::Cursor;
use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Blocks, Compression, Encoding, FlatSamples, LayerAttributes, LineOrder,
    MetaData, ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};

use crate::atomic::atomic_write;
use crate::error::ImageError;
use crate::planar::{Channel, Image};
use crate::read::{MAX_SAMPLES, check_size};

/// Writes every channel of `image` as 32-bit float under its own name, atomically (encoded in
/// memory, then [`atomic_write`]). Byte-identical output for identical images.
pub fn write_exr(path: &Path, image: &Image) -> Result<(), ImageError> {
    write_exr_owned(path, image.clone())
}

/// [`write_exr`] of an image the caller gives up: its planes go to the encoder as they are,
/// without a copy (a 1080p film with its AOVs: 91 MB).
pub fn write_exr_owned(path: &Path, image: Image) -> Result<(), ImageError> {
    let bytes = encode_exr(image).map_err(|message| ImageError::encode(path, message))?;
    atomic_write(path, &bytes)
}

fn encode_exr(image: Image) -> Result<Vec<u8>, String> {
    image.validate().map_err(|e| e.to_string())?;
    if image.width == 0 || image.height == 0 {
        return Err(format!("an EXR cannot be {}x{}", image.width, image.height));
    }
    if image.channels.is_empty() {
        return Err("the image has no channels".to_string());
    }
    let mut channels = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    let (width, height) = (image.width as usize, image.height as usize);
    for Channel { name, data } in image.channels {
        let text = Text::new_or_none(&name)
            .filter(|_| !name.is_empty())
            .ok_or_else(|| format!("channel name '{name}' is empty or not Latin-1"))?;
        channels.push(AnyChannel::new(text, FlatSamples::F32(data)));
    }
    let encoding =
        Encoding { compression: Compression::PIZ, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let layer =
        exr::prelude::Layer::new((width, height), LayerAttributes::default(), encoding, AnyChannels::sort(channels));
    let mut out = Cursor::new(Vec::new());
    exr::prelude::Image::from_layer(layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// One channel of an [`ExrTable`], stored as it is: 32-bit floats or 32-bit unsigned integers.
#[derive(Clone, Debug, PartialEq)]
pub enum TableData {
    F32(Vec<f32>),
    U32(Vec<u32>),
}

/// An EXR as a table of exact values: named f32 and u32 channels of one size and text
/// attributes in the header. What a file holds that is not an image to look at (glint's chunk
/// files of per-pixel integer sums): nothing is converted on the way in or out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrTable {
    pub width: u32,
    pub height: u32,
    pub channels: Vec<(String, TableData)>,
    /// Header attributes of type `string`, by name.
    pub attributes: Vec<(String, String)>,
}

impl ExrTable {
    /// The channel called `name`.
    #[must_use]
    pub fn channel(&self, name: &str) -> Option<&TableData> {
        self.channels.iter().find(|(n, _)| n == name).map(|(_, d)| d)
    }

    /// The text attribute called `name`.
    #[must_use]
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }
}

/// Writes `table` (one scan-line layer, lossless RLE, channels sorted by name, its text
/// attributes in the header) atomically, like [`write_exr`]. The same table gives the same
/// bytes when it has at most one attribute (the exr crate holds attributes in a hash map, so
/// the order of several varies from run to run; their values do not).
pub fn write_exr_table(path: &Path, table: &ExrTable) -> Result<(), ImageError> {
    let bytes = encode_table(table).map_err(|message| ImageError::encode(path, message))?;
    atomic_write(path, &bytes)
}

fn encode_table(table: &ExrTable) -> Result<Vec<u8>, String> {
    if table.width == 0 || table.height == 0 {
        return Err(format!("an EXR cannot be {}x{}", table.width, table.height));
    }
    if table.channels.is_empty() {
        return Err("the table has no channels".to_string());
    }
    let n = table.width as usize * table.height as usize;
    let latin1 = |what: &str, name: &str| {
        Text::new_or_none(name)
            .filter(|_| !name.is_empty())
            .ok_or_else(|| format!("{what} '{name}' is empty or not Latin-1"))
    };
    let mut channels = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (name, data) in &table.channels {
        let (len, samples) = match data {
            TableData::F32(v) => (v.len(), FlatSamples::F32(v.clone())),
            TableData::U32(v) => (v.len(), FlatSamples::U32(v.clone())),
        };
        if len != n {
            return Err(format!("channel '{name}' holds {len} values, not {n}"));
        }
        channels.push(AnyChannel::new(latin1("channel name", name)?, samples));
    }
    let mut attributes = LayerAttributes::default();
    for (name, value) in &table.attributes {
        attributes.other.insert(latin1("attribute name", name)?, AttributeValue::Text(latin1("attribute", value)?));
    }
    // RLE, not ZIP: a table's low words are noise that deflate cannot shrink (measured: ZIP cost
    // a 1024×768 chunk about 1.4 s of CPU), while its high words are runs of 0 or !0.
    let encoding =
        Encoding { compression: Compression::RLE, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let layer = exr::prelude::Layer::new(
        (table.width as usize, table.height as usize),
        attributes,
        encoding,
        AnyChannels::sort(channels),
    );
    let mut out = Cursor::new(Vec::new());
    exr::prelude::Image::from_layer(layer).write().to_buffered(&mut out).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// Reads an EXR written by [`write_exr_table`]: one layer, f32 and u32 channels as stored
/// (half channels are refused: they cannot hold what a table holds), the header's text
/// attributes. Sizes are checked against the read limits before pixels are allocated.
pub fn read_exr_table(path: &Path) -> Result<ExrTable, ImageError> {
    let bytes = std::fs::read(path).map_err(|e| ImageError::io(path, e))?;
    if !bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return Err(ImageError::decode(path, "not an OpenEXR file (no EXR magic number)"));
    }
    let meta = MetaData::read_from_buffered(Cursor::new(&bytes), false).map_err(|e| exr_error(path, e))?;
    let [header] = meta.headers.as_slice() else {
        return Err(ImageError::decode(path, format!("{} layers, expected one", meta.headers.len())));
    };
    let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
    check_size(path, w, h)?;
    if w * h * header.channels.list.len() as u64 > MAX_SAMPLES {
        return Err(ImageError::Limits {
            path: path.to_path_buf(),
            message: format!(
                "{} channels of {w}x{h}; glint reads at most {MAX_SAMPLES} values",
                header.channels.list.len()
            ),
        });
    }
    let exr_image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(&bytes))
        .map_err(|e| exr_error(path, e))?;
    let layer = &exr_image.layer_data;
    let mut table = ExrTable { width: layer.size.0 as u32, height: layer.size.1 as u32, ..ExrTable::default() };
    for channel in &layer.channel_data.list {
        let data = match &channel.sample_data {
            FlatSamples::F32(v) => TableData::F32(v.clone()),
            FlatSamples::U32(v) => TableData::U32(v.clone()),
            FlatSamples::F16(_) => {
                return Err(ImageError::decode(path, format!("channel '{}' is half precision", channel.name)));
            }
        };
        table.channels.push((channel.name.to_string(), data));
    }
    for (name, value) in &layer.attributes.other {
        if let AttributeValue::Text(text) = value {
            table.attributes.push((name.to_string(), text.to_string()));
        }
    }
    table.attributes.sort();
    Ok(table)
}

/// Reads every channel of every layer as f32 (half and uint samples are converted). Channels
/// of a named layer are called `layer.channel`. The data window is the image; the display
/// window is ignored. Deep data, subsampled channels and layers of different sizes are
/// rejected; mip/rip maps yield their largest level.
pub(crate) fn read_exr(path: &Path, bytes: &[u8]) -> Result<Image, ImageError> {
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| exr_error(path, e))?;
    let mut total = 0u64;
    for header in meta.headers.iter() {
        let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
        check_size(path, w, h)?;
        total += w * h * header.channels.list.len() as u64;
    }
    // Every channel becomes a plane, so bound the planes of all layers together.
    if total > MAX_SAMPLES {
        return Err(ImageError::Limits {
            path: path.to_path_buf(),
            message: format!("{total} samples in all layers and channels; glint reads at most {MAX_SAMPLES}"),
        });
    }

    let exr_image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| exr_error(path, e))?;

    let mut image: Option<Image> = None;
    for layer in exr_image.layer_data.iter() {
        let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
        let image = image.get_or_insert_with(|| Image::new(w, h));
        if (image.width, image.height) != (w, h) {
            return Err(ImageError::decode(
                path,
                format!("layers of different sizes ({}x{} and {w}x{h}) are not supported", image.width, image.height),
            ));
        }
        let prefix = layer.attributes.layer_name.as_ref().map(|n| format!("{n}.")).unwrap_or_default();
        for channel in &layer.channel_data.list {
            if channel.sampling != exr::prelude::Vec2(1, 1) {
                return Err(ImageError::decode(path, format!("channel '{}' is subsampled", channel.name)));
            }
            let data = match &channel.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => other.values_as_f32().collect(),
            };
            let name = format!("{prefix}{}", channel.name);
            image.add_channel(name, data).map_err(|e| ImageError::decode(path, e.to_string()))?;
        }
    }
    image.ok_or_else(|| ImageError::decode(path, "the file has no layers"))
}

fn exr_error(path: &Path, error: exr::error::Error) -> ImageError {
    match error {
        exr::error::Error::Io(source) if source.kind() != std::io::ErrorKind::UnexpectedEof => {
            ImageError::io(path, source)
        }
        exr::error::Error::Io(_) => ImageError::decode(path, "the file is truncated"),
        other => ImageError::decode(path, other.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::read_image;
    use crate::test_dir::TestDir;

    /// Values that a lossy or converting path would disturb: NaN payloads, ±∞, −0, denormals.
    fn awkward(i: usize, salt: u32) -> f32 {
        let specials =
            [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, f32::MIN_POSITIVE / 3.0, f32::MAX, 1.0e-30, -7.25];
        if i % 11 == 3 {
            specials[(i / 11 + salt as usize) % specials.len()]
        } else {
            f32::from_bits((i as u32).wrapping_mul(2_654_435_761).wrapping_add(salt) % 0x7f00_0000)
        }
    }

    fn many_channels(w: u32, h: u32) -> Image {
        let mut image = Image::new(w, h);
        let names = ["R", "G", "B", "A", "Z", "Albedo.R", "Albedo.G", "Albedo.B", "Ns.X", "Ns.Y", "Ns.Z", "direct.R"];
        for (salt, name) in names.iter().enumerate() {
            let data = (0..(w * h) as usize).map(|i| awkward(i, salt as u32 * 977)).collect();
            image.add_channel(*name, data).expect("channel");
        }
        image
    }

    fn bits(data: &[f32]) -> Vec<u32> {
        data.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn round_trip_is_bit_exact_with_named_channels() {
        let dir = TestDir::new("exr-round-trip");
        for (w, h) in [(1, 1), (17, 5), (5, 17), (64, 33)] {
            let image = many_channels(w, h);
            let path = dir.join(&format!("rt-{w}x{h}.exr"));
            write_exr(&path, &image).expect("write");
            let back = read_image(&path).expect("read");
            assert_eq!((back.width, back.height), (w, h));
            assert_eq!(back.channels.len(), image.channels.len());
            for c in &image.channels {
                let got = back.channel(&c.name).unwrap_or_else(|| panic!("{w}x{h}: lost channel {}", c.name));
                assert_eq!(bits(got), bits(&c.data), "{w}x{h} channel {}", c.name);
            }
        }
    }

    #[test]
    fn larger_multi_channel_image_round_trips() {
        // More samples in total than one side's limit: the per-file sample bound must not bite.
        let dir = TestDir::new("exr-larger");
        let path = dir.join("big.exr");
        let image = many_channels(700, 90);
        write_exr(&path, &image).expect("write");
        let back = read_image(&path).expect("read");
        for c in &image.channels {
            assert_eq!(bits(back.channel(&c.name).expect("channel")), bits(&c.data), "{}", c.name);
        }
    }

    #[test]
    fn writing_twice_gives_identical_bytes() {
        let dir = TestDir::new("exr-twice");
        let image = many_channels(70, 40);
        let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
        write_exr(&a, &image).expect("a");
        write_exr(&b, &image).expect("b");
        let (a, b) = (std::fs::read(a).expect("a"), std::fs::read(b).expect("b"));
        assert!(a == b, "two writes of the same image differ");
        assert_eq!(encode_exr(image.clone()).expect("encode"), a);
    }

    #[test]
    fn header_is_increasing_piz_f32() {
        let bytes = encode_exr(many_channels(3, 2)).expect("encode");
        let meta = MetaData::read_from_buffered(Cursor::new(&bytes), true).expect("meta");
        assert_eq!(meta.headers.len(), 1);
        let header = &meta.headers[0];
        assert_eq!(header.line_order, LineOrder::Increasing);
        assert_eq!(header.compression, Compression::PIZ);
        assert!(header.channels.list.iter().all(|c| c.sample_type == exr::prelude::SampleType::F32));
        assert!(header.own_attributes.other.is_empty() && header.shared_attributes.other.is_empty());
        assert!(header.own_attributes.software_name.is_none());
    }

    #[test]
    fn unencodable_images_are_errors() {
        let dir = TestDir::new("exr-bad");
        let path = dir.join("bad.exr");
        let err = write_exr(&path, &Image::new(2, 2)).expect_err("no channels");
        assert!(matches!(err, ImageError::Encode { .. }) && err.to_string().contains("bad.exr"), "{err}");
        let mut image = Image::new(1, 1);
        image.add_channel("λ", vec![0.0]).expect("add");
        assert!(write_exr(&path, &image).is_err());
        assert!(!path.exists());
    }

    #[test]
    fn huge_header_is_rejected_before_allocating() {
        let mut bytes = encode_exr(many_channels(4, 4)).expect("encode");
        // Patch the data window (box2i: xMin, yMin, xMax, yMax) to claim 10^6 x 10^6 pixels.
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).expect("dataWindow attribute") + key.len() + 4;
        for (k, v) in [0i32, 0, 999_999, 999_999].iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        let dir = TestDir::new("exr-huge");
        let path = dir.join("huge.exr");
        std::fs::write(&path, &bytes).expect("write");
        let err = read_image(&path).expect_err("must reject");
        assert!(matches!(err, ImageError::Limits { .. }), "{err}");
        assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
    }

    #[test]
    fn tables_round_trip_exactly_with_attributes() {
        let dir = TestDir::new("exr-table");
        let path = dir.join("t.exr");
        let (w, h) = (13u32, 7u32);
        let n = (w * h) as usize;
        let table = ExrTable {
            width: w,
            height: h,
            channels: vec![
                ("sum.R.0".into(), TableData::U32((0..n as u32).map(|i| i.wrapping_mul(2_654_435_761)).collect())),
                ("sum.R.3".into(), TableData::U32(vec![u32::MAX; n])),
                ("Z".into(), TableData::F32((0..n).map(|i| awkward(i, 5)).collect())),
            ],
            attributes: vec![("glint.chunk".into(), "2/7".into()), ("glint.hash".into(), "00ff".into())],
        };
        write_exr_table(&path, &table).expect("write");
        let back = read_exr_table(&path).expect("read");
        assert_eq!((back.width, back.height, back.attributes.clone()), (w, h, table.attributes.clone()));
        for (name, data) in &table.channels {
            match (data, back.channel(name).expect("channel")) {
                (TableData::U32(a), TableData::U32(b)) => assert_eq!(a, b, "{name}"),
                (TableData::F32(a), TableData::F32(b)) => assert_eq!(bits(a), bits(b), "{name}"),
                _ => panic!("{name}: type changed"),
            }
        }
        // A plain image is not refused, it just has no attributes; a truncated table is.
        let bytes = std::fs::read(&path).expect("bytes");
        std::fs::write(&path, &bytes[..bytes.len() - 9]).expect("cut");
        let err = read_exr_table(&path).expect_err("truncated");
        assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
        std::fs::write(&path, b"P6 not an exr").expect("foreign");
        let err = read_exr_table(&path).expect_err("foreign");
        assert!(err.to_string().contains("not an OpenEXR"), "{err}");
    }

    #[test]
    fn truncated_exr_is_a_decode_error() {
        let bytes = encode_exr(many_channels(30, 20)).expect("encode");
        let dir = TestDir::new("exr-trunc");
        for cut in [3, 40, bytes.len() / 2, bytes.len() - 1] {
            let path = dir.join("cut.exr");
            std::fs::write(&path, &bytes[..cut]).expect("write");
            let err = read_image(&path).expect_err("must fail");
            assert!(matches!(err, ImageError::Decode { .. }), "cut {cut}: {err}");
        }
    }
}
