//! Which kernel answers a query: the public queries of [`WideBvh`] (`intersect`, `occluded`,
//! their `_isa` forms and the 8-ray forms), written once for both widths.
//!
//! A [`Query`] (closest hit or any hit) picks the walk of `walk.rs`; the instruction set picks,
//! per width ([`Kernels`]), the kernel that walk runs with: 4-wide nodes have a scalar, an SSE2
//! and an AVX2 kernel, 8-wide nodes a scalar and an AVX2 one. The choice is one `match` on the
//! `Isa` per ray and every kernel is a static call, as when each query and width had its own
//! copy of the match.
//!
//! The traits are `pub` in this private module (sealed: nothing outside the crate can name or
//! implement them) because the public queries are bounded by [`Kernels`].

use super::scalar::ScalarKernel;
use super::walk::{self, Kernel};
use super::{Isa, WideBvh};
#[cfg(target_arch = "x86_64")]
use super::{avx2, packet, sse::F4, traverse::SimdKernel};
use crate::Hit;
use crate::bvh2::ray_is_traceable;
use glint_core::Ray;

/// What a walk asks of the tree, and its answer for one ray.
pub trait Query {
    type Out: Copy;
    /// The answer for an empty tree or a ray that cannot be traced.
    const MISS: Self::Out;
    /// The walk with kernel `K`; the tree is not empty and the ray is traceable.
    fn walk<const N: usize, K: Kernel<N>>(bvh: &WideBvh<N>, ray: &Ray) -> Self::Out;
    /// Up to 8 rays through the 8-wide packet kernel (`packet.rs`); the tree is not empty and
    /// AVX2 + FMA were detected.
    #[cfg(target_arch = "x86_64")]
    fn packet(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [Self::Out; 8]);
}

/// The closest hit.
pub struct Closest;

/// Any hit (shadow rays).
pub struct Any;

impl Query for Closest {
    type Out = Option<Hit>;
    const MISS: Option<Hit> = None;

    #[inline(always)]
    fn walk<const N: usize, K: Kernel<N>>(bvh: &WideBvh<N>, ray: &Ray) -> Option<Hit> {
        walk::closest::<N, K>(bvh, ray)
    }

    #[cfg(target_arch = "x86_64")]
    fn packet(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [Option<Hit>; 8]) {
        packet::intersect8(bvh, rays, out);
    }
}

impl Query for Any {
    type Out = bool;
    const MISS: bool = false;

    #[inline(always)]
    fn walk<const N: usize, K: Kernel<N>>(bvh: &WideBvh<N>, ray: &Ray) -> bool {
        walk::occluded::<N, K>(bvh, ray)
    }

    #[cfg(target_arch = "x86_64")]
    fn packet(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [bool; 8]) {
        packet::occluded8(bvh, rays, out);
    }
}

/// The kernels of one node width, by instruction set.
pub trait Kernels {
    /// `Q` for one ray with the kernel of `isa`; an `isa` the machine lacks falls back to the
    /// best one it has. The tree is not empty and the ray is traceable.
    fn run<Q: Query>(&self, isa: Isa, ray: &Ray) -> Q::Out;
}

impl Kernels for WideBvh<4> {
    fn run<Q: Query>(&self, isa: Isa, ray: &Ray) -> Q::Out {
        #[cfg(target_arch = "x86_64")]
        match isa {
            Isa::Scalar => Q::walk::<4, ScalarKernel>(self, ray),
            Isa::Sse2 => Q::walk::<4, SimdKernel<F4>>(self, ray),
            Isa::Avx2 => avx2::run4::<Q>(self, ray),
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = isa;
            Q::walk::<4, ScalarKernel>(self, ray)
        }
    }
}

impl Kernels for WideBvh<8> {
    /// Without AVX2 the 8-wide layout runs the scalar kernel.
    fn run<Q: Query>(&self, isa: Isa, ray: &Ray) -> Q::Out {
        #[cfg(target_arch = "x86_64")]
        if isa == Isa::Avx2 {
            return avx2::run8::<Q>(self, ray);
        }
        let _ = isa;
        Q::walk::<8, ScalarKernel>(self, ray)
    }
}

impl<const N: usize> WideBvh<N> {
    /// Closest hit with the portable kernel (the oracle of the SIMD kernels).
    pub fn intersect_scalar(&self, ray: &Ray) -> Option<Hit> {
        if !self.traceable(ray) {
            return None;
        }
        Closest::walk::<N, ScalarKernel>(self, ray)
    }

    /// Any hit with the portable kernel.
    pub fn occluded_scalar(&self, ray: &Ray) -> bool {
        self.traceable(ray) && Any::walk::<N, ScalarKernel>(self, ray)
    }

    /// Whether a walk has anything to do: the tree is not empty and the ray can be traced.
    fn traceable(&self, ray: &Ray) -> bool {
        !self.nodes.is_empty() && ray_is_traceable(ray)
    }
}

impl<const N: usize> WideBvh<N>
where
    Self: Kernels,
{
    /// Closest hit with the best kernel of this machine.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_isa(Isa::detect(), ray)
    }

    /// Any hit with the best kernel of this machine.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_isa(Isa::detect(), ray)
    }

    /// Closest hit with a chosen kernel (benchmarks compare them). An `isa` the machine lacks
    /// falls back to the best one it has; without AVX2 the 8-wide layout runs the scalar kernel.
    pub fn intersect_isa(&self, isa: Isa, ray: &Ray) -> Option<Hit> {
        self.query::<Closest>(isa, ray)
    }

    /// Any hit with a chosen kernel.
    pub fn occluded_isa(&self, isa: Isa, ray: &Ray) -> bool {
        self.query::<Any>(isa, ray)
    }

    fn query<Q: Query>(&self, isa: Isa, ray: &Ray) -> Q::Out {
        if !self.traceable(ray) {
            return Q::MISS;
        }
        self.run::<Q>(isa, ray)
    }
}

impl WideBvh<8> {
    /// Closest hits of up to 8 rays with a chosen kernel: with AVX2 the packet kernel
    /// (`packet.rs`), otherwise one single-ray query per ray. `out[i]` is what
    /// `intersect_isa(isa, &rays[i])` returns, bit for bit.
    pub fn intersect8_isa(&self, isa: Isa, rays: &[Ray; 8], out: &mut [Option<Hit>; 8]) {
        self.query8::<Closest>(isa, rays, out);
    }

    /// Any hits of up to 8 rays: `out[i] == occluded_isa(isa, &rays[i])`.
    pub fn occluded8_isa(&self, isa: Isa, rays: &[Ray; 8], out: &mut [bool; 8]) {
        self.query8::<Any>(isa, rays, out);
    }

    fn query8<Q: Query>(&self, isa: Isa, rays: &[Ray; 8], out: &mut [Q::Out; 8]) {
        #[cfg(target_arch = "x86_64")]
        if isa == Isa::Avx2 && Isa::detect() == Isa::Avx2 && !self.nodes.is_empty() {
            return Q::packet(self, rays, out);
        }
        for (o, r) in out.iter_mut().zip(rays) {
            *o = self.query::<Q>(isa, r);
        }
    }
}
