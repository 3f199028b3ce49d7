//! Simple animations of objects and lights: a rotation about an axis and a keyframed
//! translation (issue 6, item 5).
//!
//! An animation keeps the state of its target at rest (`base`) and evaluates every time from
//! it: `world_from_object(t) = motion(t) · base`, with `motion(t) = T(offset(t)) · R_pivot(angle(t))`.
//! Nothing accumulates from frame to frame, so any time can be shown in any order without
//! drift, and a motion that is the identity at `t` (angle 0 mod 360°, offset zero) gives back
//! the rest state bit for bit. Scenes know nothing of acceleration structures: glint-render's
//! `World::set_time` turns the new placements into a top-level rebuild.

use crate::{Light, Scene, SceneError, Shape};
use glint_core::{Affine3A, Bounds3, Mat3, Vec3};

/// A steady rotation about an axis through a pivot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotation {
    /// Unit axis (right-handed: counter-clockwise seen from its tip).
    pub axis: Vec3,
    /// World-space point the axis passes through; `None`: the centre of the target's world
    /// bounds at rest (a light's position), resolved by [`Scene::animate`].
    pub pivot: Option<Vec3>,
    pub degrees_per_second: f32,
    /// Angle at `t = 0`, degrees.
    pub phase_deg: f32,
}

impl Rotation {
    /// The angle at time `t` in degrees, in `[0, 360)` (reduced in f64, so long times keep
    /// their precision).
    pub fn angle_deg(&self, t: f32) -> f32 {
        let a = (self.phase_deg as f64 + self.degrees_per_second as f64 * t as f64).rem_euclid(360.0) as f32;
        if a >= 360.0 { 0.0 } else { a }
    }

    /// The rotation matrix at time `t`; exactly the identity at an angle of 0.
    pub fn matrix_at(&self, t: f32) -> Mat3 {
        let angle = self.angle_deg(t);
        if angle == 0.0 {
            return Mat3::IDENTITY;
        }
        Mat3::from_axis_angle(self.axis.normalize_or(Vec3::Y), angle.to_radians())
    }
}

/// What keyframes do outside `[t0, tN]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Repeat {
    /// Clamp: the first key's offset before it, the last key's after it.
    Hold,
    /// Start again from the first key: the motion has period `tN − t0`.
    #[default]
    Loop,
    /// Go back and forth: period `2 (tN − t0)`.
    PingPong,
}

/// A translation given at key times, linearly interpolated between them.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Keyframes {
    /// `(time in seconds, world-space offset)`, times strictly increasing; at least one key.
    pub keys: Vec<(f32, Vec3)>,
    pub repeat: Repeat,
}

impl Keyframes {
    /// The offset at time `t` (zero without keys).
    pub fn offset_at(&self, t: f32) -> Vec3 {
        let (Some(&(t0, first)), Some(&(tn, last))) = (self.keys.first(), self.keys.last()) else {
            return Vec3::ZERO;
        };
        let period = tn as f64 - t0 as f64;
        if period <= 0.0 {
            return first;
        }
        let local = match self.repeat {
            Repeat::Hold => t,
            Repeat::Loop => (t0 as f64 + (t as f64 - t0 as f64).rem_euclid(period)) as f32,
            Repeat::PingPong => {
                let u = (t as f64 - t0 as f64).rem_euclid(2.0 * period);
                (t0 as f64 + if u > period { 2.0 * period - u } else { u }) as f32
            }
        };
        if local <= t0 {
            return first;
        }
        if local >= tn {
            return last;
        }
        // The segment [keys[i - 1], keys[i]] holds `local` (1 <= i < len, as t0 < local < tN;
        // the clamp only keeps unvalidated, unsorted keys from indexing out of bounds).
        let i = self.keys.partition_point(|&(k, _)| k <= local).clamp(1, self.keys.len() - 1);
        let ((ta, a), (tb, b)) = (self.keys[i - 1], self.keys[i]);
        let s = (local - ta) / (tb - ta);
        a + (b - a) * s
    }
}

/// A rotation, a keyframed translation, or both.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Motion {
    pub rotation: Option<Rotation>,
    pub translation: Option<Keyframes>,
}

impl Motion {
    /// `T(offset(t)) · R_pivot(angle(t))`: rotate about `pivot`, then translate. Applied on the
    /// left of the rest placement. Exactly the identity when the angle is 0 and the offset zero.
    pub fn transform_at(&self, t: f32, pivot: Vec3) -> Affine3A {
        let offset = self.translation.as_ref().map_or(Vec3::ZERO, |k| k.offset_at(t));
        let r = self.rotation.as_ref().map_or(Mat3::IDENTITY, |r| r.matrix_at(t));
        if r == Mat3::IDENTITY {
            return Affine3A::from_translation(offset);
        }
        Affine3A::from_mat3_translation(r, offset + (pivot - r * pivot))
    }
}

/// What an animation moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnimationTarget {
    /// Index into `Scene::objects`.
    Object(usize),
    /// Index into `Scene::lights`.
    Light(usize),
}

/// The target as it is at rest, from which every time is evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnimationBase {
    /// The object's placement and shape at rest (a plane's equation is its shape: planes are
    /// moved by transforming it).
    Object {
        world_from_object: Affine3A,
        shape: Shape,
    },
    Light(Light),
}

/// One animated object or light.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    pub target: AnimationTarget,
    pub motion: Motion,
    /// The world-space pivot of the rotation, resolved when the animation was added.
    pub pivot: Vec3,
    pub base: AnimationBase,
}

impl Animation {
    /// The target's placement at time `t`. `None` for a light target.
    fn object_at(&self, t: f32) -> Option<(Affine3A, Shape)> {
        let AnimationBase::Object { world_from_object, shape } = self.base else { return None };
        let m = self.motion.transform_at(t, self.pivot);
        if m == Affine3A::IDENTITY {
            return Some((world_from_object, shape));
        }
        Some(match shape {
            // The plane p·n + d = 0 through p0 = −d n: rotate the normal, move the point.
            Shape::Plane { normal, offset } => {
                let n = (m.matrix3 * normal).normalize_or(normal);
                let p0 = m.transform_point3(-offset * normal);
                (world_from_object, Shape::Plane { normal: n, offset: -p0.dot(n) })
            }
            Shape::Sphere { .. } | Shape::Mesh(_) => (m * world_from_object, shape),
        })
    }

    /// The light at time `t`. `None` for an object target.
    fn light_at(&self, t: f32) -> Option<Light> {
        let AnimationBase::Light(base) = self.base else { return None };
        let m = self.motion.transform_at(t, self.pivot);
        if m == Affine3A::IDENTITY {
            return Some(base);
        }
        let turn = |d: Vec3| (m.matrix3 * d).normalize_or(d);
        Some(match base {
            Light::Point { position, colour, intensity, attenuation } => {
                Light::Point { position: m.transform_point3(position), colour, intensity, attenuation }
            }
            Light::Directional { direction, colour, intensity } => {
                Light::Directional { direction: turn(direction), colour, intensity }
            }
            Light::Spot {
                position,
                direction,
                inner_deg,
                outer_deg,
                colour,
                intensity,
                attenuation,
                falloff,
                projection,
            } => Light::Spot {
                position: m.transform_point3(position),
                direction: turn(direction),
                inner_deg,
                outer_deg,
                colour,
                intensity,
                attenuation,
                falloff,
                projection: projection.map(|p| crate::light::SpotProjection {
                    right: turn(p.right),
                    up: turn(p.up),
                    ..p
                }),
            },
        })
    }
}

impl Scene {
    /// Animate `targets` together with one motion (a model file's several meshes turn as one).
    /// Their current state becomes the rest state; the rotation's pivot, unless given, is the
    /// centre of the targets' world bounds now (a plane: its point nearest the origin; a
    /// positional light: its position; directional lights add nothing, and alone pivot at the
    /// origin, which does not change how they turn). Call [`Scene::set_time`] afterwards to put
    /// the scene at a time.
    pub fn animate(&mut self, targets: &[AnimationTarget], motion: Motion) -> Result<(), SceneError> {
        let mut bounds = Bounds3::EMPTY;
        let mut bases = Vec::with_capacity(targets.len());
        for &target in targets {
            let base = match target {
                AnimationTarget::Object(i) => {
                    let o = self.objects.get(i).ok_or(SceneError::BadReference {
                        what: "animation".into(),
                        kind: "object",
                        index: i,
                        count: self.objects.len(),
                    })?;
                    bounds = bounds.union(match o.shape {
                        Shape::Plane { normal, offset } => Bounds3::from_point(-offset * normal),
                        _ => self.object_bounds(o),
                    });
                    AnimationBase::Object { world_from_object: o.world_from_object, shape: o.shape }
                }
                AnimationTarget::Light(i) => {
                    let l = self.lights.get(i).ok_or(SceneError::BadReference {
                        what: "animation".into(),
                        kind: "light",
                        index: i,
                        count: self.lights.len(),
                    })?;
                    if let Some(p) = l.position() {
                        bounds = bounds.grow(p);
                    }
                    AnimationBase::Light(*l)
                }
            };
            bases.push((target, base));
        }
        let pivot = match motion.rotation.and_then(|r| r.pivot) {
            Some(p) => p,
            None if bounds.is_empty() => Vec3::ZERO,
            None => bounds.centre(),
        };
        for (target, base) in bases {
            self.animations.push(Animation { target, motion: motion.clone(), pivot, base });
        }
        Ok(())
    }

    /// Whether anything in the scene moves.
    pub fn is_animated(&self) -> bool {
        !self.animations.is_empty()
    }

    /// Put every animated object and light where it is at time `t` (seconds), evaluated from
    /// its rest state. Targets out of range (an unvalidated scene) are skipped.
    pub fn set_time(&mut self, t: f32) {
        for a in &self.animations {
            match a.target {
                AnimationTarget::Object(i) => {
                    if let (Some(o), Some((world_from_object, shape))) = (self.objects.get_mut(i), a.object_at(t)) {
                        o.world_from_object = world_from_object;
                        o.shape = shape;
                    }
                }
                AnimationTarget::Light(i) => {
                    if let (Some(l), Some(light)) = (self.lights.get_mut(i), a.light_at(t)) {
                        *l = light;
                    }
                }
            }
        }
    }

    pub(crate) fn validate_animation(&self, index: usize, a: &Animation) -> Result<(), SceneError> {
        let what = || format!("animation #{index} ({:?})", a.target);
        let invalid = |message: &str| Err(SceneError::invalid(what(), message));
        let (kind, count, i) = match a.target {
            AnimationTarget::Object(i) => ("object", self.objects.len(), i),
            AnimationTarget::Light(i) => ("light", self.lights.len(), i),
        };
        if i >= count {
            return Err(SceneError::BadReference { what: what(), kind, index: i, count });
        }
        match (a.target, &a.base) {
            (AnimationTarget::Object(_), AnimationBase::Object { world_from_object, .. }) => {
                if !world_from_object.is_finite() || world_from_object.matrix3.determinant().abs() < 1e-12 {
                    return invalid("the rest transform is not finite and invertible");
                }
            }
            (AnimationTarget::Light(_), AnimationBase::Light(_)) => {}
            _ => return invalid("its rest state is of another kind than its target"),
        }
        if self.animations[..index].iter().any(|b| b.target == a.target) {
            return invalid("the target is animated twice (give one animation both a rotation and keyframes)");
        }
        if !a.pivot.is_finite() {
            return invalid("the pivot must be finite");
        }
        if a.motion.rotation.is_none() && a.motion.translation.is_none() {
            return invalid("needs a rotation or keyframes");
        }
        if let Some(r) = &a.motion.rotation {
            if !r.axis.is_finite() || r.axis.try_normalize().is_none() {
                return invalid("the rotation axis must be a finite, non-zero vector");
            }
            if !r.degrees_per_second.is_finite() || !r.phase_deg.is_finite() {
                return invalid("degrees per second and the phase must be finite");
            }
            if r.pivot.is_some_and(|p| !p.is_finite()) {
                return invalid("the pivot must be finite");
            }
        }
        if let Some(k) = &a.motion.translation {
            if k.keys.is_empty() {
                return invalid("keyframes need at least one key");
            }
            if k.keys.iter().any(|(t, o)| !t.is_finite() || !o.is_finite()) {
                return invalid("key times and offsets must be finite");
            }
            if let Some(w) = k.keys.windows(2).position(|w| w[1].0 <= w[0].0) {
                return invalid(&format!("key times must increase strictly (key {} is not after key {w})", w + 1));
            }
            if matches!(a.base, AnimationBase::Light(Light::Directional { .. })) {
                return invalid("a directional light has no position to translate (rotate it instead)");
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Material, Object};
    use glint_core::Rgb;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    fn spin(dps: f32, pivot: Option<Vec3>) -> Rotation {
        Rotation { axis: Vec3::Y, pivot, degrees_per_second: dps, phase_deg: 0.0 }
    }

    #[test]
    fn rotation_angle_grows_with_time_and_wraps() {
        let r = Rotation { phase_deg: 30.0, ..spin(45.0, None) };
        assert_eq!(r.angle_deg(0.0), 30.0);
        assert_eq!(r.angle_deg(2.0), 120.0);
        assert_eq!(r.angle_deg(8.0), 30.0);
        assert_eq!(r.angle_deg(-1.0), 345.0);
        assert_eq!(spin(90.0, None).matrix_at(4.0), Mat3::IDENTITY);
        // Long times keep their precision.
        assert!((spin(10.0, None).angle_deg(36_000.5) - 5.0).abs() < 1e-4);
    }

    #[test]
    fn rotation_turns_about_its_axis_through_the_pivot() {
        let pivot = Vec3::new(1.0, 0.0, 0.0);
        let m = Motion { rotation: Some(spin(90.0, Some(pivot))), translation: None };
        // A quarter turn about +Y through (1, 0, 0): (2, 0, 0) → (1, 0, −1); the pivot stays.
        let a = m.transform_at(1.0, pivot);
        assert!(close(a.transform_point3(Vec3::new(2.0, 0.0, 0.0)), Vec3::new(1.0, 0.0, -1.0)));
        assert!(close(a.transform_point3(pivot), pivot));
        assert!(close(a.transform_point3(Vec3::new(1.0, 5.0, 0.0)), Vec3::new(1.0, 5.0, 0.0)));
        // Half a turn about an unnormalised X axis.
        let r = Rotation { axis: Vec3::new(3.0, 0.0, 0.0), ..spin(180.0, None) };
        let m = Motion { rotation: Some(r), translation: None };
        assert!(close(m.transform_at(1.0, Vec3::ZERO).transform_point3(Vec3::Y), -Vec3::Y));
        assert_eq!(m.transform_at(0.0, Vec3::new(4.0, 5.0, 6.0)), Affine3A::IDENTITY);
    }

    fn keys(repeat: Repeat) -> Keyframes {
        Keyframes { keys: vec![(1.0, Vec3::ZERO), (2.0, Vec3::new(0.0, 2.0, 0.0)), (3.0, Vec3::X)], repeat }
    }

    #[test]
    fn keyframes_interpolate_linearly_between_keys() {
        for repeat in [Repeat::Hold, Repeat::Loop, Repeat::PingPong] {
            let k = keys(repeat);
            assert_eq!(k.offset_at(1.0), Vec3::ZERO, "{repeat:?}");
            assert_eq!(k.offset_at(1.5), Vec3::new(0.0, 1.0, 0.0), "{repeat:?}");
            assert_eq!(k.offset_at(2.0), Vec3::new(0.0, 2.0, 0.0), "{repeat:?}");
            assert!(close(k.offset_at(2.25), Vec3::new(0.25, 1.5, 0.0)), "{repeat:?}");
        }
    }

    #[test]
    fn hold_clamps_before_the_first_and_after_the_last_key() {
        let k = keys(Repeat::Hold);
        assert_eq!(k.offset_at(-5.0), Vec3::ZERO);
        assert_eq!(k.offset_at(3.0), Vec3::X);
        assert_eq!(k.offset_at(100.0), Vec3::X);
    }

    #[test]
    fn loop_wraps_over_the_keys() {
        let k = keys(Repeat::Loop);
        // Period 2: 4.5 ≡ 2.5, 0.5 ≡ 2.5 (before the first key), 3 ≡ 1.
        assert!(close(k.offset_at(4.5), Vec3::new(0.5, 1.0, 0.0)));
        assert!(close(k.offset_at(0.5), Vec3::new(0.5, 1.0, 0.0)));
        assert_eq!(k.offset_at(3.0), Vec3::ZERO);
        assert!(close(k.offset_at(-8.5), k.offset_at(1.5)));
    }

    #[test]
    fn ping_pong_goes_back_and_forth() {
        let k = keys(Repeat::PingPong);
        // Period 4: 3.5 mirrors to 2.5, 4 to 2, 5 back to 1; before the first key it mirrors too.
        assert!(close(k.offset_at(3.5), Vec3::new(0.5, 1.0, 0.0)));
        assert!(close(k.offset_at(4.0), Vec3::new(0.0, 2.0, 0.0)));
        assert!(close(k.offset_at(5.0), Vec3::ZERO));
        assert!(close(k.offset_at(0.5), k.offset_at(1.5)));
        assert!(close(k.offset_at(-1.0), Vec3::X));
        assert!(close(k.offset_at(7.5), k.offset_at(2.5)));
    }

    #[test]
    fn one_key_is_constant() {
        for repeat in [Repeat::Hold, Repeat::Loop, Repeat::PingPong] {
            let k = Keyframes { keys: vec![(2.0, Vec3::Z)], repeat };
            assert_eq!(k.offset_at(-1.0), Vec3::Z);
            assert_eq!(k.offset_at(9.0), Vec3::Z);
        }
    }

    #[test]
    fn motion_rotates_about_the_pivot_then_translates() {
        let pivot = Vec3::new(0.0, 0.0, 2.0);
        let m = Motion {
            rotation: Some(spin(90.0, None)),
            translation: Some(Keyframes { keys: vec![(0.0, Vec3::ZERO), (1.0, Vec3::Y)], repeat: Repeat::Hold }),
        };
        let a = m.transform_at(1.0, pivot);
        // (1, 0, 2) turns about the pivot to (0, 0, 1), then rises by 1.
        assert!(close(a.transform_point3(Vec3::new(1.0, 0.0, 2.0)), Vec3::new(0.0, 1.0, 1.0)));
    }

    fn scene() -> Scene {
        Scene {
            materials: vec![Material::default()],
            objects: vec![
                Object {
                    name: "ball".into(),
                    shape: Shape::Sphere { centre: Vec3::new(1.0, 0.0, 0.0), radius: 0.5 },
                    material: 0,
                    world_from_object: Affine3A::from_translation(Vec3::new(0.0, 0.0, -3.0)),
                },
                Object {
                    name: "floor".into(),
                    shape: Shape::Plane { normal: Vec3::Y, offset: 1.0 },
                    material: 0,
                    world_from_object: Affine3A::IDENTITY,
                },
            ],
            lights: vec![
                Light::Point {
                    position: Vec3::new(0.0, 4.0, 0.0),
                    colour: Rgb::ONE,
                    intensity: 1.0,
                    attenuation: Default::default(),
                },
                Light::Spot {
                    position: Vec3::new(2.0, 4.0, 0.0),
                    direction: -Vec3::Y,
                    inner_deg: 10.0,
                    outer_deg: 20.0,
                    colour: Rgb::ONE,
                    intensity: 1.0,
                    attenuation: Default::default(),
                    falloff: Default::default(),
                    projection: None,
                },
            ],
            ..Scene::default()
        }
    }

    fn rise() -> Motion {
        Motion {
            rotation: None,
            translation: Some(Keyframes {
                keys: vec![(0.0, Vec3::ZERO), (2.0, Vec3::new(0.0, 2.0, 0.0))],
                ..Default::default()
            }),
        }
    }

    #[test]
    fn set_time_moves_objects_and_lights_from_their_rest_state() {
        let mut s = scene();
        let rest = s.clone();
        s.animate(&[AnimationTarget::Object(0)], Motion { rotation: Some(spin(90.0, None)), translation: None })
            .expect("in range");
        s.animate(&[AnimationTarget::Object(1), AnimationTarget::Light(0)], rise()).expect("in range");
        s.animate(
            &[AnimationTarget::Light(1)],
            Motion { rotation: Some(Rotation { axis: Vec3::Z, ..spin(90.0, None) }), translation: None },
        )
        .expect("in range");
        assert!(s.is_animated());
        assert_eq!(s.validate(), Ok(()));
        // The ball's pivot is its own centre (1, 0, −3): turning leaves it in place.
        assert!(close(s.animations[0].pivot, Vec3::new(1.0, 0.0, -3.0)));
        s.set_time(1.0);
        let ball = s.objects[0].world_from_object;
        assert!(close(ball.transform_point3(Vec3::new(1.0, 0.0, 0.0)), Vec3::new(1.0, 0.0, -3.0)));
        assert!(close(ball.transform_point3(Vec3::new(2.0, 0.0, 0.0)), Vec3::new(1.0, 0.0, -4.0)));
        let Shape::Plane { normal, offset } = s.objects[1].shape else { panic!("a plane") };
        assert!(close(normal, Vec3::Y) && (offset - 0.0).abs() < 1e-6, "{normal} {offset}");
        assert_eq!(s.lights[0].position(), Some(Vec3::new(0.0, 5.0, 0.0)));
        let Light::Spot { position, direction, .. } = s.lights[1] else { panic!("a spot") };
        assert!(close(position, Vec3::new(2.0, 4.0, 0.0)) && close(direction, Vec3::X), "{direction}");
        assert_eq!(s.validate(), Ok(()));
        // Back at 0 everything is as it was, bit for bit; and any order of times agrees.
        s.set_time(0.0);
        assert_eq!((&s.objects, &s.lights), (&rest.objects, &rest.lights));
        s.set_time(0.7);
        let once = s.objects.clone();
        s.set_time(3.1);
        s.set_time(0.7);
        assert_eq!(s.objects, once);
    }

    #[test]
    fn bad_animations_are_rejected() {
        let base = {
            let mut s = scene();
            s.animate(&[AnimationTarget::Object(0)], rise()).expect("in range");
            s
        };
        assert_eq!(base.validate(), Ok(()));
        let check = |f: &dyn Fn(&mut Animation), want: &str| {
            let mut s = base.clone();
            f(&mut s.animations[0]);
            let e = s.validate().expect_err(want);
            assert!(e.to_string().contains(want), "{e}");
        };
        check(&|a| a.target = AnimationTarget::Object(7), "refers to object #7");
        check(&|a| a.target = AnimationTarget::Light(0), "another kind");
        check(&|a| a.pivot = Vec3::NAN, "pivot");
        check(&|a| a.motion.translation = None, "needs a rotation or keyframes");
        check(&|a| a.motion.rotation = Some(Rotation { axis: Vec3::ZERO, ..spin(1.0, None) }), "axis");
        check(&|a| a.motion.rotation = Some(spin(f32::INFINITY, None)), "finite");
        check(&|a| a.motion.rotation = Some(spin(1.0, Some(Vec3::NAN))), "pivot");
        let keys = |k: Vec<(f32, Vec3)>| {
            move |a: &mut Animation| a.motion.translation = Some(Keyframes { keys: k.clone(), repeat: Repeat::Loop })
        };
        check(&keys(vec![]), "at least one key");
        check(&keys(vec![(0.0, Vec3::ZERO), (0.0, Vec3::X)]), "increase strictly");
        check(&keys(vec![(1.0, Vec3::ZERO), (0.5, Vec3::X)]), "increase strictly");
        check(&keys(vec![(f32::NAN, Vec3::ZERO)]), "finite");
        check(&keys(vec![(0.0, Vec3::INFINITY)]), "finite");
        let mut s = base.clone();
        s.animate(&[AnimationTarget::Object(0)], rise()).expect("in range");
        assert!(s.validate().expect_err("twice").to_string().contains("twice"));
        let mut s = base.clone();
        s.lights.push(Light::Directional { direction: -Vec3::Y, colour: Rgb::ONE, intensity: 1.0 });
        s.animate(&[AnimationTarget::Light(2)], rise()).expect("in range");
        assert!(s.validate().expect_err("directional").to_string().contains("directional"));
        assert!(base.clone().animate(&[AnimationTarget::Light(9)], rise()).is_err());
    }
}
