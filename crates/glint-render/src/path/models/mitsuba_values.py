#!/usr/bin/env python3
"""Reference values of glint's BSDF models from Mitsuba 3 itself.

Prints Rust source: by default the test module `mitsuba_reference.rs` beside this script,
holding Mitsuba 3's eval, pdf and sample results for a fixed list of (model, parameters, wo,
wi) cases; with `--presets` glint-scene's `presets.rs`: the RGB eta/k of every conductor Mitsuba
ships (its `material` parameter) and its named dielectric indices (include/mitsuba/render/ior.h),
as Mitsuba itself reports them. Regenerate with

    python3 mitsuba_values.py > mitsuba_reference.rs
    python3 mitsuba_values.py --presets > ../../../../../glint-scene/src/presets.rs
    cargo fmt --all

(needs `pip install mitsuba`; written against Mitsuba 3.6, variant scalar_rgb).

Naming: glint's `wo` (toward the viewer) is Mitsuba's `si.wi`; glint's `wi` (toward the light)
is Mitsuba's `wo`. The shading frame is the identity.
"""
import math
import os
import struct
import sys

import mitsuba as mi

mi.set_variant("scalar_rgb")
mi.set_log_level(mi.LogLevel.Error)


def f32(x):
    """The shortest decimal that reads back as the same f32 (a Rust literal)."""
    x = struct.unpack("f", struct.pack("f", float(x)))[0]
    for digits in range(1, 10):
        s = "%.*g" % (digits, x)
        if struct.unpack("f", struct.pack("f", float(s)))[0] == x:
            break
    if "e" in s:
        mantissa, exponent = s.split("e")
        s = (mantissa if "." in mantissa else mantissa + ".0") + "e" + str(int(exponent))
    elif "." not in s and "inf" not in s and "nan" not in s:
        s += ".0"
    return s


def rgb(c):
    return "Rgb::new(%s, %s, %s)" % tuple(f32(x) for x in c)


def vec(v):
    return "Vec3::new(%s, %s, %s)" % tuple(f32(x) for x in v)


def norm(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def color(c):
    return {"type": "rgb", "value": list(c)}


def micro(dist, au, av, vis):
    return (
        "Microfacet::new(Distribution::%s, %s, %s, %s)"
        % ("Beckmann" if dist == "beckmann" else "Ggx", f32(au), f32(av), "true" if vis else "false")
    )


# Each model: (Mitsuba dict, Rust expression of the same model).
def diffuse(r):
    return {"type": "diffuse", "reflectance": color(r)}, "Model::Diffuse { reflectance: %s }" % rgb(r)


def roughconductor(dist, au, av, vis, eta, k, spec):
    d = {"type": "roughconductor", "distribution": dist, "alpha_u": au, "alpha_v": av, "sample_visible": vis,
         "eta": mi.ScalarColor3f(*eta), "k": mi.ScalarColor3f(*k), "specular_reflectance": color(spec)}
    r = "Model::RoughConductor { micro: %s, eta: %s, k: %s, specular_reflectance: %s }" % (
        micro(dist, au, av, vis), rgb(eta), rgb(k), rgb(spec))
    return d, r


def roughdielectric(dist, au, av, vis, eta, refl, trans):
    d = {"type": "roughdielectric", "distribution": dist, "alpha_u": au, "alpha_v": av, "sample_visible": vis,
         "int_ior": eta, "ext_ior": 1.0, "specular_reflectance": color(refl), "specular_transmittance": color(trans)}
    r = ("Model::RoughDielectric { micro: %s, eta: %s, specular_reflectance: %s, specular_transmittance: %s }"
         % (micro(dist, au, av, vis), f32(eta), rgb(refl), rgb(trans)))
    return d, r


def plastic(diff, spec, eta, nonlinear):
    d = {"type": "plastic", "diffuse_reflectance": color(diff), "specular_reflectance": color(spec),
         "int_ior": eta, "ext_ior": 1.0, "nonlinear": nonlinear}
    r = ("Model::Plastic { diffuse_reflectance: %s, specular_reflectance: %s, eta: %s, nonlinear: %s }"
         % (rgb(diff), rgb(spec), f32(eta), "true" if nonlinear else "false"))
    return d, r


def roughplastic(dist, alpha, vis, diff, spec, eta, nonlinear):
    d = {"type": "roughplastic", "distribution": dist, "alpha": alpha, "sample_visible": vis,
         "diffuse_reflectance": color(diff), "specular_reflectance": color(spec), "int_ior": eta, "ext_ior": 1.0,
         "nonlinear": nonlinear}
    r = ("Model::RoughPlastic { micro: %s, diffuse_reflectance: %s, specular_reflectance: %s, eta: %s, nonlinear: %s }"
         % (micro(dist, alpha, alpha, vis), rgb(diff), rgb(spec), f32(eta), "true" if nonlinear else "false"))
    return d, r


PRINCIPLED_FLOATS = ["roughness", "anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint",
                     "flatness", "clearcoat", "clearcoat_gloss", "diff_trans"]


def principled(thin, base, eta=None, specular=None, **params):
    d = {"type": "principledthin" if thin else "principled", "base_color": color(base)}
    for k, v in params.items():
        d[k] = v
    if eta is not None:
        d["eta"] = eta
    if specular is not None:
        d["specular"] = specular
    # The index as glint's reader resolves it (Mitsuba does not report it).
    eta_value = "PrincipledParams::resolve_eta(%s, %s, %s, %s)" % (
        "true" if thin else "false", "None" if eta is None else "Some(%s)" % f32(eta),
        f32(0.5 if specular is None else specular), "true" if "spec_trans" in params else "false")
    fields = ", ".join("%s: %s" % (k, f32(params.get(k, 0.5 if k == "roughness" else 0.0)))
                       for k in PRINCIPLED_FLOATS)
    r = "Model::Principled(PrincipledParams { thin: %s, base_color: %s, %s, eta: %s })" % (
        "true" if thin else "false", rgb(base), fields, eta_value)
    return d, r


def models():
    out = [diffuse([0.8, 0.5, 0.2])]
    for dist in ["beckmann", "ggx"]:
        for (au, av, vis) in [(0.1, 0.1, True), (0.4, 0.4, False), (0.15, 0.5, True), (0.3, 0.08, False)]:
            out.append(roughconductor(dist, au, av, vis, [0.2, 0.92, 1.1], [3.9, 2.45, 2.2], [1.0, 0.9, 0.8]))
        for (au, av, vis, eta) in [(0.1, 0.1, True, 1.5), (0.35, 0.35, False, 1.33), (0.1, 0.3, True, 1.5),
                                   (0.25, 0.25, True, 1 / 1.4)]:
            out.append(roughdielectric(dist, au, av, vis, eta, [1.0, 0.9, 0.8], [0.7, 0.8, 0.9]))
        for (alpha, vis, nl) in [(0.1, True, False), (0.3, False, True), (0.5, True, True)]:
            out.append(roughplastic(dist, alpha, vis, [0.6, 0.3, 0.1], [1.0, 0.95, 0.9], 1.49, nl))
    for nl in [False, True]:
        out.append(plastic([0.6, 0.3, 0.1], [1.0, 0.95, 0.9], 1.5, nl))
    base = [0.9, 0.55, 0.25]
    out.append(principled(False, base))
    out.append(principled(False, base, roughness=0.3, metallic=0.6, spec_tint=0.4, sheen=0.7, sheen_tint=0.5))
    out.append(principled(False, base, roughness=0.45, anisotropic=0.6, clearcoat=0.8, clearcoat_gloss=0.4,
                          flatness=0.5, specular=0.7))
    out.append(principled(False, base, roughness=0.25, spec_trans=0.7, eta=1.33, metallic=0.1))
    out.append(principled(True, base, roughness=0.35, spec_trans=0.6, diff_trans=0.8, sheen=0.5, eta=1.4))
    out.append(principled(True, base, roughness=0.6, anisotropic=0.5, spec_tint=0.4, flatness=0.3,
                          spec_trans=0.3, sheen_tint=0.6, sheen=0.3))
    return out


WO = [norm(v) for v in [[0.3, 0.2, 0.9], [-0.6, 0.3, 0.5], [0.5, -0.4, -0.6]]]
WI = [norm(v) for v in [[-0.25, -0.1, 0.95], [0.5, 0.45, 0.4], [-0.3, -0.2, -0.85], [0.1, 0.6, -0.5],
                        [0.7, -0.6, 0.3]]]
SAMPLES = [(0.1, (0.3, 0.7)), (0.45, (0.8, 0.2)), (0.8, (0.55, 0.45)), (0.97, (0.15, 0.9))]


def interaction(wo):
    si = mi.SurfaceInteraction3f()
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    si.wi = mi.Vector3f(*wo)
    return si


def main():
    ctx = mi.BSDFContext()
    print("//! Mitsuba 3's own values for the models (generated by mitsuba_values.py with Mitsuba %s;"
          % mi.__version__)
    print("//! do not edit). Naming as glint: `wo` toward the viewer, `wi` toward the light.")
    print()
    print("use super::{Microfacet, Model, PrincipledParams};")
    print("use glint_core::{Rgb, Vec2, Vec3};")
    print("use glint_scene::bsdf::Distribution;")
    print()
    print("/// (model, wo, wi, Mitsuba's eval, Mitsuba's pdf).")
    print("pub fn eval_cases() -> Vec<(Model, Vec3, Vec3, Rgb, f32)> {")
    print("    vec![")
    sample_lines = []
    for d, r in models():
        bsdf = mi.load_dict(d)
        for wo in WO:
            si = interaction(wo)
            for wi in WI:
                e = bsdf.eval(ctx, si, mi.Vector3f(*wi))
                p = bsdf.pdf(ctx, si, mi.Vector3f(*wi))
                print("        (%s, %s, %s, %s, %s)," % (r, vec(wo), vec(wi), rgb(e), f32(p)))
            for (u1, u2) in SAMPLES:
                bs, w = bsdf.sample(ctx, si, u1, mi.Point2f(*u2))
                if float(max(w)) <= 0.0:
                    continue
                sample_lines.append("        (%s, %s, %s, Vec2::new(%s, %s), %s, %s, %s)," % (
                    r, vec(wo), f32(u1), f32(u2[0]), f32(u2[1]), vec(bs.wo), rgb(w), f32(bs.pdf)))
    print("    ]")
    print("}")
    print()
    print("/// (model, wo, u_lobe, u, Mitsuba's sampled wi, weight, pdf) for samples of non-zero weight.")
    print("pub fn sample_cases() -> Vec<(Model, Vec3, f32, Vec2, Vec3, Rgb, f32)> {")
    print("    vec![")
    for line in sample_lines:
        print(line)
    print("    ]")
    print("}")
    print()


IOR_NAMES = ["vacuum", "helium", "hydrogen", "air", "carbon dioxide", "water", "acetone", "ethanol",
             "carbon tetrachloride", "glycerol", "benzene", "silicone oil", "bromine", "water ice",
             "fused quartz", "pyrex", "acrylic glass", "polypropylene", "bk7", "sodium chloride", "amber",
             "pet", "diamond"]


def presets():
    ior_dir = os.path.join(os.path.dirname(mi.__file__), "data", "ior")
    names = sorted({f[: -len(".eta.spd")] for f in os.listdir(ior_dir) if f.endswith(".eta.spd")})
    print("//! Mitsuba 3's named materials: the complex index (RGB `eta`, `k`) of every conductor it")
    print("//! ships for `conductor`/`roughconductor`'s `material` parameter (its spectral data in")
    print("//! data/ior/*.spd reduced to RGB by Mitsuba %s's scalar_rgb variant, read back with" % mi.__version__)
    print("//! `mi.traverse`), and the named dielectric indices of include/mitsuba/render/ior.h. Generated by")
    print("//! mitsuba_values.py --presets; do not edit. A reader of Mitsuba XML calls these.")
    print()
    print("use glint_core::Rgb;")
    print()
    print("/// (name, eta, k), sorted by name; `none` is Mitsuba's default (eta 0, k 1).")
    print("const CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[")
    for name in names + ["none"]:
        p = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        eta, k = p["eta.value"], p["k.value"]
        eta = [float(eta)] * 3 if isinstance(eta, float) else [float(x) for x in eta]
        k = [float(k)] * 3 if isinstance(k, float) else [float(x) for x in k]
        print('    ("%s", [%s, %s, %s], [%s, %s, %s]),' % ((name,) + tuple(f32(x) for x in eta + k)))
    print("];")
    print()
    print("/// (name, index) of Mitsuba's named dielectrics.")
    print("const IORS: &[(&str, f32)] = &[")
    for name in IOR_NAMES:
        p = mi.traverse(mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": 1.0}))
        print('    ("%s", %s),' % (name, f32(p["eta"])))
    print("];")
    print(PRESET_FUNCTIONS)


PRESET_FUNCTIONS = """
/// The RGB complex index `(eta, k)` of Mitsuba's conductor `material` (`"Au"`, `"Cu_palik"`,
/// `"none"`, ...; exact, case-sensitive names as Mitsuba).
pub fn conductor_preset(name: &str) -> Option<(Rgb, Rgb)> {
    CONDUCTORS.iter().find(|c| c.0 == name).map(|&(_, eta, k)| (Rgb::from(eta), Rgb::from(k)))
}

/// The index of refraction of Mitsuba's named dielectric (`"bk7"`, `"water"`, ...; Mitsuba's
/// lower-case names).
pub fn ior_preset(name: &str) -> Option<f32> {
    IORS.iter().find(|c| c.0 == name).map(|c| c.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_hold_mitsubas_materials() {
        for name in ["Au", "Ag", "Al", "Cu", "Cr", "a-C", "W", "Hg", "none"] {
            assert!(conductor_preset(name).is_some(), "{name}");
        }
        assert_eq!(conductor_preset("none"), Some((Rgb::ZERO, Rgb::ONE)));
        assert_eq!(conductor_preset("gold"), None);
        // Gold reflects red more than blue: eta smaller, k larger in red.
        let (eta, k) = conductor_preset("Au").expect("gold");
        assert!(eta.x < eta.z && k.x > k.z);
        assert_eq!(ior_preset("bk7"), Some(1.5046));
        assert_eq!(ior_preset("vacuum"), Some(1.0));
        assert_eq!(ior_preset("diamond"), Some(2.419));
        assert_eq!(ior_preset("unobtainium"), None);
        assert!(CONDUCTORS.windows(2).all(|w| w[0].0 < w[1].0 || w[1].0 == "none"));
    }
}"""

if __name__ == "__main__":
    if sys.argv[1:] == ["--presets"]:
        presets()
    else:
        main()
