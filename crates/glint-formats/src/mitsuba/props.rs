//! A plugin element's properties (`<float>`, `<rgb>`, `<transform>`, nested objects, `<ref>`)
//! parsed and typed, and marked as they are read, so that what no reader asked for is
//! reported (Mitsuba rejects unreferenced properties too). Transforms compose as Mitsuba's
//! parser does: each operation left-multiplies what came before (src/core/parser.cpp).

use super::xml::{Element, Loc};
use crate::error::FormatError;
use glint_core::glam::{DMat3, DMat4, DVec3, DVec4};
use std::cell::Cell;
use std::collections::HashMap;

/// A spectrum as written: one value for all wavelengths, or `wavelength:value` pairs.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Spectrum {
    Uniform(f64),
    List { wavelengths: Vec<f64>, values: Vec<f64> },
}

#[derive(Clone, Debug)]
pub(super) enum Value<'a> {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(&'a str),
    Vector(DVec3),
    Rgb([f64; 3]),
    Spectrum(Spectrum),
    Transform(DMat4),
    /// A nested plugin or the target of a `<ref>`.
    Object(&'a Element),
}

impl Value<'_> {
    fn kind(&self) -> &'static str {
        match self {
            Value::Bool(_) => "boolean",
            Value::Int(_) => "integer",
            Value::Float(_) => "float",
            Value::Str(_) => "string",
            Value::Vector(_) => "point/vector",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Transform(_) => "transform",
            Value::Object(_) => "object",
        }
    }
}

pub(super) struct Prop<'a> {
    pub name: String,
    pub value: Value<'a>,
    /// The element that gave the value (for messages).
    pub at: &'a Element,
    used: Cell<bool>,
}

/// The properties of one plugin element.
pub(super) struct Props<'a> {
    pub el: &'a Element,
    /// The `type` attribute.
    pub plugin: &'a str,
    props: Vec<Prop<'a>>,
}

/// Elements with an `id`, by id.
pub(super) type Ids<'a> = HashMap<&'a str, &'a Element>;

const OBJECT_TAGS: [&str; 12] = [
    "bsdf",
    "texture",
    "shape",
    "emitter",
    "sensor",
    "film",
    "sampler",
    "integrator",
    "rfilter",
    "medium",
    "phase",
    "volume",
];

pub(super) fn is_object_tag(tag: &str) -> bool {
    OBJECT_TAGS.contains(&tag)
}

impl<'a> Props<'a> {
    /// Parses the children of `el`. Nested objects without a `name` are listed in order with
    /// an empty name (`unnamed`).
    pub fn parse(el: &'a Element, ids: &Ids<'a>) -> Result<Props<'a>, FormatError> {
        let plugin = el.attr("type").unwrap_or("");
        let mut props: Vec<Prop<'a>> = Vec::new();
        for c in &el.children {
            let name = c.attr("name").unwrap_or("").to_string();
            let value = match c.tag.as_str() {
                "ref" => {
                    let id = c.required("id")?;
                    let target =
                        ids.get(id).ok_or_else(|| c.loc.error(format!("<ref id=\"{id}\">: no object has this id")))?;
                    Value::Object(target)
                }
                t if is_object_tag(t) => Value::Object(c),
                "alias" => continue,
                _ => parse_value(c)?,
            };
            if !matches!(value, Value::Object(_)) && name.is_empty() {
                return Err(c.loc.error(format!("<{}> needs a 'name' attribute", c.tag)));
            }
            if !name.is_empty() && props.iter().any(|p| p.name == name) {
                return Err(c.loc.error(format!("property '{name}' of {} is given twice", el.describe())));
            }
            props.push(Prop { name, value, at: c, used: Cell::new(false) });
        }
        Ok(Props { el, plugin, props })
    }

    pub fn loc(&self) -> &Loc {
        &self.el.loc
    }

    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    /// The property (marked as read).
    pub fn get(&self, name: &str) -> Option<&Prop<'a>> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    /// Marks properties that glint reads and ignores (they do not change the picture glint
    /// makes, e.g. a film's pixel format).
    pub fn ignore(&self, names: &[&str]) {
        for n in names {
            let _ = self.get(n);
        }
    }

    fn wrong(&self, p: &Prop, want: &str) -> FormatError {
        p.at.loc.error(format!(
            "property '{}' of {} is a {}, expected {want}",
            p.name,
            self.el.describe(),
            p.value.kind()
        ))
    }

    pub fn float(&self, name: &str, default: f64) -> Result<f64, FormatError> {
        self.float_opt(name).map(|v| v.unwrap_or(default))
    }

    pub fn float_opt(&self, name: &str) -> Result<Option<f64>, FormatError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        match p.value {
            Value::Float(v) => Ok(Some(v)),
            Value::Int(v) => Ok(Some(v as f64)),
            _ => Err(self.wrong(p, "a float")),
        }
    }

    pub fn int(&self, name: &str, default: i64) -> Result<i64, FormatError> {
        let Some(p) = self.get(name) else { return Ok(default) };
        match p.value {
            Value::Int(v) => Ok(v),
            _ => Err(self.wrong(p, "an integer")),
        }
    }

    /// A non-negative integer that fits u32.
    pub fn count(&self, name: &str, default: u32) -> Result<u32, FormatError> {
        let v = self.int(name, i64::from(default))?;
        u32::try_from(v).map_err(|_| {
            let at = self.get(name).map_or(self.loc(), |p| &p.at.loc);
            at.error(format!("{name} = {v} must be a whole number from 0 to {}", u32::MAX))
        })
    }

    pub fn boolean(&self, name: &str, default: bool) -> Result<bool, FormatError> {
        let Some(p) = self.get(name) else { return Ok(default) };
        match p.value {
            Value::Bool(v) => Ok(v),
            _ => Err(self.wrong(p, "a boolean")),
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<&'a str>, FormatError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        match p.value {
            Value::Str(s) => Ok(Some(s)),
            _ => Err(self.wrong(p, "a string")),
        }
    }

    pub fn vector(&self, name: &str) -> Result<Option<DVec3>, FormatError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        match p.value {
            Value::Vector(v) => Ok(Some(v)),
            _ => Err(self.wrong(p, "a point or vector")),
        }
    }

    pub fn transform(&self, name: &str) -> Result<Option<DMat4>, FormatError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        match p.value {
            Value::Transform(m) => Ok(Some(m)),
            _ => Err(self.wrong(p, "a <transform>")),
        }
    }

    /// Nested objects of a tag (`bsdf`, `texture`, …) without a name, in order (marked).
    pub fn unnamed(&self, tag: &str) -> Vec<&'a Element> {
        self.props
            .iter()
            .filter(|p| p.name.is_empty())
            .filter_map(|p| match p.value {
                Value::Object(o) if o.tag == tag => {
                    p.used.set(true);
                    Some(o)
                }
                _ => None,
            })
            .collect()
    }

    /// Every nested object of a tag, named or not (marked).
    pub fn objects(&self, tag: &str) -> Vec<(&str, &'a Element)> {
        self.props
            .iter()
            .filter_map(|p| match p.value {
                Value::Object(o) if o.tag == tag => {
                    p.used.set(true);
                    Some((p.name.as_str(), o))
                }
                _ => None,
            })
            .collect()
    }

    /// Properties no reader asked for: (element, description).
    pub fn unused(&self) -> Vec<(&'a Element, String)> {
        self.props
            .iter()
            .filter(|p| !p.used.get())
            .map(|p| {
                let what = if p.name.is_empty() {
                    format!("nested {}", p.at.describe())
                } else {
                    format!("property '{}'", p.name)
                };
                (p.at, format!("{what} of {} is not used by glint", self.el.describe()))
            })
            .collect()
    }
}

/// A finite number.
pub(super) fn number(s: &str, at: &Element) -> Result<f64, FormatError> {
    let t = s.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(at.loc.error(format!("{}: '{t}' is not a finite number", at.describe()))),
        Err(_) => Err(at.loc.error(format!("{}: '{t}' is not a number", at.describe()))),
    }
}

/// Numbers separated by commas and/or spaces.
pub(super) fn numbers(s: &str, at: &Element) -> Result<Vec<f64>, FormatError> {
    s.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).map(|t| number(t, at)).collect()
}

fn parse_value(c: &Element) -> Result<Value<'_>, FormatError> {
    let value = || c.required("value");
    Ok(match c.tag.as_str() {
        "float" => Value::Float(number(value()?, c)?),
        "integer" => {
            let v = value()?.trim();
            Value::Int(v.parse::<i64>().map_err(|_| c.loc.error(format!("<integer>: '{v}' is not a whole number")))?)
        }
        "boolean" => Value::Bool(match value()?.trim().to_ascii_lowercase().as_str() {
            "true" => true,
            "false" => false,
            other => return Err(c.loc.error(format!("<boolean>: '{other}' is neither true nor false"))),
        }),
        "string" => Value::Str(value()?),
        "point" | "vector" => Value::Vector(vec3(c, 0.0)?),
        "rgb" | "color" => {
            let v = numbers(value()?, c)?;
            match v.len() {
                1 => Value::Rgb([v[0]; 3]),
                3 => Value::Rgb([v[0], v[1], v[2]]),
                n => return Err(c.loc.error(format!("<rgb> has {n} numbers, expected 1 or 3"))),
            }
        }
        "spectrum" => {
            if c.attr("filename").is_some() {
                return Err(c.loc.error("<spectrum filename=…> (spectra from files) is not supported by glint"));
            }
            Value::Spectrum(spectrum(value()?, c)?)
        }
        "transform" => Value::Transform(transform(c)?),
        other => return Err(c.loc.error(format!("unknown element <{other}>"))),
    })
}

fn spectrum(s: &str, c: &Element) -> Result<Spectrum, FormatError> {
    if !s.contains(':') {
        let v = numbers(s, c)?;
        return match v.as_slice() {
            [x] => Ok(Spectrum::Uniform(*x)),
            _ => Err(c.loc.error("<spectrum value> is one number or a list of wavelength:value pairs")),
        };
    }
    let (mut wavelengths, mut values) = (Vec::new(), Vec::new());
    for pair in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let Some((w, v)) = pair.split_once(':') else {
            return Err(c.loc.error(format!("<spectrum>: '{pair}' is not wavelength:value")));
        };
        let (w, v) = (number(w, c)?, number(v, c)?);
        if wavelengths.last().is_some_and(|&last| w <= last) {
            return Err(c.loc.error(format!("<spectrum>: wavelength {w} does not increase")));
        }
        wavelengths.push(w);
        values.push(v);
    }
    Ok(Spectrum::List { wavelengths, values })
}

/// `value="x, y, z"` or `x=… y=… z=…` attributes (missing ones `default`).
pub(super) fn vec3(c: &Element, default: f64) -> Result<DVec3, FormatError> {
    if let Some(v) = c.attr("value") {
        if c.attr("x").is_some() || c.attr("y").is_some() || c.attr("z").is_some() {
            return Err(c.loc.error(format!("{}: give either 'value' or x/y/z", c.describe())));
        }
        let n = numbers(v, c)?;
        return match n.as_slice() {
            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
            _ => Err(c.loc.error(format!("<{}> value has {} numbers, expected 3", c.tag, n.len()))),
        };
    }
    let get = |a: &str| c.attr(a).map_or(Ok(default), |s| number(s, c));
    Ok(DVec3::new(get("x")?, get("y")?, get("z")?))
}

fn point_attr(c: &Element, name: &str) -> Result<DVec3, FormatError> {
    let n = numbers(c.required(name)?, c)?;
    match n.as_slice() {
        [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(c.loc.error(format!("<{}> {name} has {} numbers, expected 3", c.tag, n.len()))),
    }
}

/// Mitsuba's `coordinate_system` (Duff et al. 2017): the first tangent of a unit vector.
pub(super) fn any_perpendicular(n: DVec3) -> DVec3 {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(n.x * n.x * a * sign + 1.0, sign * b, -sign * n.x)
}

/// Mitsuba's `Transform4f::look_at`: columns left, up, dir, origin.
pub(super) fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let up = if up.length_squared() == 0.0 { any_perpendicular(dir) } else { up };
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0)))
}

/// The matrix of a `<transform>` element: its operations in order, each left-multiplied.
pub(super) fn transform(t: &Element) -> Result<DMat4, FormatError> {
    let mut m = DMat4::IDENTITY;
    for op in &t.children {
        let step = match op.tag.as_str() {
            "translate" => DMat4::from_translation(vec3(op, 0.0)?),
            "scale" => {
                let s = match op.attr("value") {
                    Some(v) if op.attr("x").is_none() && op.attr("y").is_none() && op.attr("z").is_none() => {
                        match numbers(v, op)?.as_slice() {
                            [s] => DVec3::splat(*s),
                            [x, y, z] => DVec3::new(*x, *y, *z),
                            _ => return Err(op.loc.error("<scale value> is one number or three")),
                        }
                    }
                    _ => vec3(op, 1.0)?,
                };
                DMat4::from_scale(s)
            }
            "rotate" => {
                let axis = vec3(op, 0.0)?;
                let angle = number(op.required("angle")?, op)?;
                let axis = axis.try_normalize().ok_or_else(|| op.loc.error("<rotate> axis has zero length"))?;
                DMat4::from_axis_angle(axis, angle.to_radians())
            }
            "matrix" => {
                let v = numbers(op.required("value")?, op)?;
                match v.len() {
                    16 => DMat4::from_cols_array(&v.try_into().unwrap_or([0.0; 16])).transpose(),
                    9 => DMat4::from_mat3(DMat3::from_cols_array(&v.try_into().unwrap_or([0.0; 9])).transpose()),
                    n => return Err(op.loc.error(format!("<matrix> has {n} numbers, expected 16 (or 9), row major"))),
                }
            }
            "lookat" => {
                let origin = point_attr(op, "origin")?;
                let target = point_attr(op, "target")?;
                let up = if op.attr("up").is_some() { point_attr(op, "up")? } else { DVec3::ZERO };
                look_at(origin, target, up)
                    .ok_or_else(|| op.loc.error("<lookat>: target equals origin, or up is parallel to the view"))?
            }
            other => return Err(op.loc.error(format!("unknown transform operation <{other}>"))),
        };
        m = step * m;
    }
    if !m.is_finite() {
        return Err(t.loc.error("<transform> is not finite"));
    }
    Ok(m)
}

/// The last row of a projective matrix, which glint's affine transforms cannot hold.
pub(super) fn is_affine(m: &DMat4) -> bool {
    m.row(3) == DVec4::new(0.0, 0.0, 0.0, 1.0)
}
