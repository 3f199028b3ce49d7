//! Validation at the border: sizes, finiteness and parameter domains, checked before any
//! filter runs so that the kernels never see a bad value and never need a `Result`.

use rayon::prelude::*;

use crate::{FilterError, Guide};

/// The names errors give the seven planes a filter reads.
pub(crate) struct Names<'a> {
    pub input: [&'a str; 3],
    /// normal x, y, z, depth.
    pub guide: [&'a str; 4],
}

impl Names<'static> {
    pub(crate) const DEFAULT: Names<'static> = Names {
        input: ["input[0] (R)", "input[1] (G)", "input[2] (B)"],
        guide: ["normal.x", "normal.y", "normal.z", "depth"],
    };
}

/// Checks that `guide` has a non-zero size and that all seven planes hold `width * height`
/// values. Returns `(width, height)`.
pub(crate) fn sizes(input: [&[f32]; 3], guide: &Guide, names: &Names) -> Result<(usize, usize), FilterError> {
    let (width, height) = (guide.width, guide.height);
    if width == 0 || height == 0 {
        return Err(FilterError::Empty { width, height });
    }
    let expected = width.checked_mul(height);
    for (name, plane) in planes(input, guide, names) {
        if Some(plane.len()) != expected {
            return Err(FilterError::SizeMismatch {
                plane: name.to_string(),
                len: plane.len(),
                width,
                height,
                expected: expected.unwrap_or(usize::MAX),
            });
        }
    }
    Ok((width, height))
}

/// Checks that the caller's output planes hold `width * height` values each.
pub(crate) fn outputs(out: &[&mut [f32]; 3], width: usize, height: usize) -> Result<(), FilterError> {
    for (c, plane) in out.iter().enumerate() {
        if plane.len() != width * height {
            return Err(FilterError::SizeMismatch {
                plane: format!("output[{c}]"),
                len: plane.len(),
                width,
                height,
                expected: width * height,
            });
        }
    }
    Ok(())
}

/// Fails on the first non-finite value of the seven planes (sizes already checked).
pub(crate) fn finite(input: [&[f32]; 3], guide: &Guide, names: &Names) -> Result<(), FilterError> {
    finite_planes(&planes(input, guide, names), guide.width)
}

fn planes<'a>(input: [&'a [f32]; 3], guide: &Guide<'a>, names: &Names<'a>) -> [(&'a str, &'a [f32]); 7] {
    [
        (names.input[0], input[0]),
        (names.input[1], input[1]),
        (names.input[2], input[2]),
        (names.guide[0], guide.normal[0]),
        (names.guide[1], guide.normal[1]),
        (names.guide[2], guide.normal[2]),
        (names.guide[3], guide.depth),
    ]
}

/// Elements per parallel work item of the finiteness scan.
const CHUNK: usize = 1 << 15;

/// Fails on the first non-finite value, planes in order, pixels row-major within a plane.
pub(crate) fn finite_planes(planes: &[(&str, &[f32])], width: usize) -> Result<(), FilterError> {
    let items: Vec<(usize, usize)> = planes
        .iter()
        .enumerate()
        .flat_map(|(p, (_, data))| (0..data.len().div_ceil(CHUNK)).map(move |c| (p, c)))
        .collect();
    let bad = items.par_iter().find_first(|&&(p, c)| {
        let data = planes[p].1;
        let chunk = &data[c * CHUNK..data.len().min((c + 1) * CHUNK)];
        // A branch-free OR over the chunk vectorises; the position is searched only on failure.
        chunk.iter().fold(false, |bad, v| bad | !v.is_finite())
    });
    if let Some(&(p, c)) = bad {
        let (name, data) = planes[p];
        let start = c * CHUNK;
        if let Some(i) = data[start..].iter().position(|v| !v.is_finite()) {
            let i = start + i;
            return Err(FilterError::NotFinite { plane: name.to_string(), x: i % width, y: i / width, value: data[i] });
        }
    }
    Ok(())
}

/// `value` must be finite and > 0.
pub(crate) fn positive(filter: &'static str, name: &str, value: f32) -> Result<(), FilterError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(FilterError::parameter(filter, format!("{name} must be finite and > 0, got {value}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_bad_pixel_is_reported_in_row_major_order() {
        let w = 300;
        let mut a = vec![0.0f32; w * 400];
        let mut b = vec![0.0f32; w * 400];
        a[w * 399 + 2] = f32::INFINITY;
        a[w * 399 + 7] = f32::NAN;
        b[5] = f32::NAN;
        let planes = [("a", &a[..]), ("b", &b[..])];
        let err = finite_planes(&planes, w).expect_err("inf");
        assert_eq!(err, FilterError::NotFinite { plane: "a".into(), x: 2, y: 399, value: f32::INFINITY });
        let planes = [("b", &b[..]), ("a", &a[..])];
        let err = finite_planes(&planes, w).expect_err("nan");
        assert!(err.to_string().starts_with("b is not finite at pixel (5, 0)"), "{err}");
        a.fill(1.0);
        assert!(finite_planes(&[("a", &a[..])], w).is_ok());
    }
}
