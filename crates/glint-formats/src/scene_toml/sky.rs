//! `background` and `[sky]` → [`Sky`]: a colour, a gradient (zenith, horizon, ground), or a
//! cube map / lat-long image read here through [`load_sky`] (docs/skies.md).
//!
//! Read after the camera. A key that does not apply to the sky's type (a colour on a map sky,
//! face fixes on a lat-long image) is an error at its line, and the images are checked to be
//! what `type` says before the sky enters the scene.

use super::Builder;
use super::defs::{Flip, SkyDef, SkyKind, Span};
use super::values::V3;
use crate::error::FormatError;
use crate::sky::{FaceTransform, LoadedSky, SkyLoadOptions, SkySource, load_sky};
use glint_scene::{CubeFace, Sky};
use toml::Spanned;

fn flip_transform(f: Flip) -> FaceTransform {
    FaceTransform {
        flip_horizontal: matches!(f, Flip::Horizontal | Flip::Both),
        flip_vertical: matches!(f, Flip::Vertical | Flip::Both),
        rotate_degrees: 0,
    }
}

impl Builder<'_> {
    pub(super) fn sky(
        &mut self,
        sky: Option<&Spanned<SkyDef>>,
        background: Option<&Spanned<V3>>,
    ) -> Result<Sky, FormatError> {
        let sky = match (sky, background) {
            (Some(_), Some(b)) => {
                return Err(self.err(&b.span(), "give either `background` or a [sky] table, not both"));
            }
            (None, Some(b)) => return Ok(Sky::Colour(self.colour(b, "background")?)),
            (None, None) => return Ok(Sky::default()),
            (Some(s), None) => s,
        };
        let def = sky.get_ref();
        self.scene.sky_ambient = def.ambient.unwrap_or(false);
        let gradient_keys = [&def.zenith, &def.horizon, &def.ground];
        let has_map = def.path.is_some() || def.faces.is_some();
        let kind = match &def.kind {
            Some(k) => *k.get_ref(),
            None if has_map => SkyKind::Cubemap, // refined by what the file holds
            None if def.colour.is_none() && gradient_keys.iter().any(|k| k.is_some()) => SkyKind::Gradient,
            None => SkyKind::Colour,
        };
        let intensity = match &def.intensity {
            Some(v) => self.non_negative(v, "intensity")?,
            None => 1.0,
        };
        let map_keys: Vec<(&'static str, Span)> = [
            ("path", def.path.as_ref().map(|v| v.span())),
            ("faces", def.faces.as_ref().map(|v| v.span())),
            ("flip", def.flip.as_ref().map(|v| v.span())),
            ("face", def.face.as_ref().map(|v| v.span())),
            ("rotation", def.rotation.as_ref().map(|v| v.span())),
        ]
        .into_iter()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .collect();
        match kind {
            SkyKind::Colour => {
                if let Some(k) = gradient_keys.iter().find_map(|k| k.as_ref()) {
                    return Err(self.err(&k.span(), "zenith/horizon/ground belong to a sky of type = \"gradient\""));
                }
                self.disallow(&map_keys, &[], "a colour sky")?;
                match &def.colour {
                    Some(c) => Ok(Sky::Colour(self.colour(c, "colour")? * intensity)),
                    None => {
                        Err(self
                            .missing(&sky.span(), "[sky] needs `colour`, `path` or `faces` (or type = \"gradient\")"))
                    }
                }
            }
            SkyKind::Gradient => {
                if let Some(c) = &def.colour {
                    return Err(self.err(&c.span(), "a gradient sky takes zenith, horizon and ground, not `colour`"));
                }
                self.disallow(&map_keys, &[], "a gradient sky")?;
                let get = |v: &Option<Spanned<V3>>, key: &str| match v {
                    Some(c) => self.colour(c, key).map(|c| c * intensity),
                    None => Err(self.missing(&sky.span(), format!("a gradient sky needs `{key}`"))),
                };
                Ok(Sky::Gradient {
                    zenith: get(&def.zenith, "zenith")?,
                    horizon: get(&def.horizon, "horizon")?,
                    ground: get(&def.ground, "ground")?,
                })
            }
            SkyKind::Cubemap | SkyKind::Latlong => self.map_sky(sky, kind, intensity),
        }
    }

    /// `[sky]` with `path` or `faces`: the images are read here (see docs/skies.md).
    fn map_sky(&mut self, sky: &Spanned<SkyDef>, kind: SkyKind, intensity: f32) -> Result<Sky, FormatError> {
        let def = sky.get_ref();
        if let Some(k) = [&def.colour, &def.zenith, &def.horizon, &def.ground].iter().find_map(|k| k.as_ref()) {
            return Err(self.err(&k.span(), "a map sky takes `path` or `faces`, not colours"));
        }
        let source = self.sky_source(sky, kind)?;
        let options = self.sky_load_options(def, intensity)?;
        let transforms = [("flip", def.flip.as_ref().map(|f| f.span())), ("face", def.face.as_ref().map(|f| f.span()))]
            .into_iter()
            .find_map(|(k, s)| s.map(|s| (k, s)));
        let loaded = match load_sky(&source, &options) {
            Ok(l) => l,
            Err(e) => {
                // Face fixes given for what turns out to be a lat-long image: say which line.
                if let Some((key, span)) = &transforms {
                    let plain =
                        SkyLoadOptions { all_faces: FaceTransform::default(), per_face: Default::default(), ..options };
                    if let Ok(LoadedSky { sky: Sky::LatLong { .. }, .. }) = load_sky(&source, &plain) {
                        return Err(
                            self.err(span, format!("`{key}` applies to cube-map faces, not to a lat-long image"))
                        );
                    }
                }
                return Err(e);
            }
        };
        let is_latlong = matches!(loaded.sky, Sky::LatLong { .. });
        if let Some(k) = &def.kind {
            let want_latlong = *k.get_ref() == SkyKind::Latlong;
            if want_latlong != is_latlong {
                let found = if is_latlong { "a lat-long image" } else { "a cube map" };
                return Err(
                    self.err(&k.span(), format!("the sky's `type` does not match its images: they hold {found}"))
                );
            }
        }
        self.warnings.extend(loaded.warnings);
        Ok(loaded.sky)
    }

    /// Where a map sky's images are: `path` (a file or a folder) or the six `faces`.
    fn sky_source(&self, sky: &Spanned<SkyDef>, kind: SkyKind) -> Result<SkySource, FormatError> {
        let def = sky.get_ref();
        match (&def.path, &def.faces) {
            (Some(_), Some(f)) => Err(self.err(&f.span(), "give either `path` or `faces`, not both")),
            (None, None) => {
                Err(self.missing(&sky.span(), "a cube-map or lat-long sky needs `path` (a file or folder) or `faces`"))
            }
            (Some(p), None) => {
                let full = self.base_dir.join(p.get_ref());
                if !full.exists() {
                    return Err(FormatError::MissingFile { file: full, referenced_from: self.place(&p.span()) });
                }
                let field = format!("line {} `path`", super::line_column(self.text, p.span().start).0);
                let by = Some(crate::files::Referrer::new(self.file, &field));
                if full.is_dir() {
                    crate::files::check_folder(&full, by)?;
                } else {
                    crate::files::check(&full, by)?;
                }
                Ok(SkySource::Path(full))
            }
            (None, Some(f)) => {
                if kind == SkyKind::Latlong {
                    return Err(self.err(&f.span(), "`faces` make a cube map, not a lat-long sky"));
                }
                let list = f.get_ref();
                if list.len() != 6 {
                    return Err(self.err(
                        &f.span(),
                        format!("`faces` needs 6 images (px, nx, py, ny, pz, nz), found {}", list.len()),
                    ));
                }
                let mut paths = Vec::with_capacity(6);
                for p in list {
                    paths.push(self.resolve(p, "faces")?);
                }
                Ok(SkySource::Faces(std::array::from_fn(|i| paths[i].clone())))
            }
        }
    }

    /// Intensity, rotation about +Y, and the flips and turns of `flip` and `[sky.face.*]`.
    fn sky_load_options(&self, def: &SkyDef, intensity: f32) -> Result<SkyLoadOptions, FormatError> {
        let mut options = SkyLoadOptions { intensity, ..SkyLoadOptions::default() };
        if let Some(r) = &def.rotation {
            options.rotation_degrees = r.get_ref().0;
        }
        if let Some(f) = &def.flip {
            options.all_faces = flip_transform(*f.get_ref());
        }
        if let Some(faces) = &def.face {
            for (name, fd) in faces.get_ref() {
                let Some(face) = CubeFace::ALL.iter().find(|f| f.short_name() == name) else {
                    return Err(self.err(
                        &fd.span(),
                        format!("unknown face `{name}` in [sky.face]: use px, nx, py, ny, pz or nz"),
                    ));
                };
                let fd = fd.get_ref();
                let mut t = fd.flip.as_ref().map_or(FaceTransform::default(), |f| flip_transform(*f.get_ref()));
                if let Some(r) = &fd.rotate {
                    let deg = *r.get_ref();
                    if ![0, 90, 180, 270].contains(&deg) {
                        return Err(self.err(&r.span(), format!("`rotate` = {deg}: use 0, 90, 180 or 270 (clockwise)")));
                    }
                    t.rotate_degrees = deg;
                }
                options.per_face[face.index()] = t;
            }
        }
        Ok(options)
    }
}
