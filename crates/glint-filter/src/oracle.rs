//! Direct, slow, f64 implementations of the filters' definitions: the oracles the fast kernels
//! are tested (and the benchmarks validated) against. Not part of the supported API.

use crate::{AtrousParams, BilateralParams, Guide, GuideChannels, GuidedParams};

/// The guide vector I of pixel i, uncentred: luma((n + 1)/2), (n + 1)/2, or (n + 1)/2 and
/// min(z, 1); unused components are 0.
fn guide_vector(guide: &Guide, channels: GuideChannels, i: usize) -> [f64; 4] {
    let n = guide.normal.map(|p| (p[i] as f64 + 1.0) * 0.5);
    match channels {
        GuideChannels::Grey => [0.2126 * n[0] + 0.7152 * n[1] + 0.0722 * n[2], 0.0, 0.0, 0.0],
        GuideChannels::Normal => [n[0], n[1], n[2], 0.0],
        GuideChannels::NormalDepth => [n[0], n[1], n[2], (guide.depth[i] as f64).min(1.0)],
    }
}

/// Solves the `d`×`d` system `m x = rhs` by Gaussian elimination with partial pivoting.
fn solve(mut m: [[f64; 4]; 4], mut rhs: [f64; 4], d: usize) -> [f64; 4] {
    for col in 0..d {
        let pivot = (col..d).fold(col, |best, r| if m[r][col].abs() > m[best][col].abs() { r } else { best });
        m.swap(col, pivot);
        rhs.swap(col, pivot);
        for r in col + 1..d {
            let f = m[r][col] / m[col][col];
            for c in col..d {
                m[r][c] -= f * m[col][c];
            }
            rhs[r] -= f * rhs[col];
        }
    }
    let mut x = [0.0; 4];
    for r in (0..d).rev() {
        let s: f64 = (r + 1..d).map(|c| m[r][c] * x[c]).sum();
        x[r] = (rhs[r] - s) / m[r][r];
    }
    x
}

/// Pixels of the window of radius `r` around (x, y), clipped to the image.
fn window(w: usize, h: usize, x: usize, y: usize, r: usize) -> impl Iterator<Item = usize> {
    let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1));
    let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1));
    (y0..=y1).flat_map(move |yy| (x0..=x1).map(move |xx| yy * w + xx))
}

/// He et al.'s guided filter straight from its equations, O(r²) per pixel, in f64.
pub fn guided_direct(input: [&[f32]; 3], guide: &Guide, p: &GuidedParams) -> [Vec<f32>; 3] {
    let (w, h, r) = (guide.width, guide.height, p.radius);
    let d = p.channels.dimension();
    let eps = [p.eps_normal, p.eps_normal, p.eps_normal, p.eps_depth].map(f64::from);
    let guides: Vec<[f64; 4]> = (0..w * h).map(|i| guide_vector(guide, p.channels, i)).collect();
    // a_k (per colour, D values) and b_k (per colour) for every window centre k.
    let mut a = vec![[[0.0f64; 4]; 3]; w * h];
    let mut b = vec![[0.0f64; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let k = y * w + x;
            let pixels: Vec<usize> = window(w, h, x, y, r).collect();
            let n = pixels.len() as f64;
            let mut mi = [0.0; 4];
            let mut mp = [0.0; 3];
            for &i in &pixels {
                for j in 0..d {
                    mi[j] += guides[i][j] / n;
                }
                for c in 0..3 {
                    mp[c] += input[c][i] as f64 / n;
                }
            }
            let mut sigma = [[0.0; 4]; 4];
            let mut cov = [[0.0; 4]; 3];
            for &i in &pixels {
                let g = guides[i];
                for j in 0..d {
                    for l in 0..d {
                        sigma[j][l] += (g[j] - mi[j]) * (g[l] - mi[l]) / n;
                    }
                    for c in 0..3 {
                        cov[c][j] += (g[j] - mi[j]) * (input[c][i] as f64 - mp[c]) / n;
                    }
                }
            }
            for j in 0..d {
                sigma[j][j] += eps[j];
            }
            for c in 0..3 {
                a[k][c] = solve(sigma, cov[c], d);
                b[k][c] = mp[c] - (0..d).map(|j| a[k][c][j] * mi[j]).sum::<f64>();
            }
        }
    }
    let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; w * h]);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let ks: Vec<usize> = window(w, h, x, y, r).collect();
            let n = ks.len() as f64;
            for c in 0..3 {
                let ma: f64 = ks.iter().map(|&k| (0..d).map(|j| a[k][c][j] * guides[i][j]).sum::<f64>()).sum();
                let mb: f64 = ks.iter().map(|&k| b[k][c]).sum();
                out[c][i] = ((ma + mb) / n) as f32;
            }
        }
    }
    out
}

/// `|n_i − n_j|²` and `(z_i − z_j)²` with depth clamped to 1, in f64.
fn geometry_distance(guide: &Guide, i: usize, j: usize) -> (f64, f64) {
    let dn: f64 = (0..3).map(|k| (guide.normal[k][i] as f64 - guide.normal[k][j] as f64).powi(2)).sum();
    let z = |i: usize| (guide.depth[i] as f64).min(1.0);
    (dn, (z(i) - z(j)).powi(2))
}

/// The cross-bilateral filter straight from its definition, in f64.
pub fn bilateral_direct(input: [&[f32]; 3], guide: &Guide, p: &BilateralParams) -> [Vec<f32>; 3] {
    let (w, h, r) = (guide.width, guide.height, p.radius);
    let [ss, sn, sz] = [p.sigma_spatial, p.sigma_normal, p.sigma_depth].map(|s| 2.0 * f64::from(s).powi(2));
    let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; w * h]);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (mut sum, mut acc) = (0.0, [0.0; 3]);
            for j in window(w, h, x, y, r) {
                let (dx, dy) = ((j % w) as f64 - x as f64, (j / w) as f64 - y as f64);
                let (dn, dz) = geometry_distance(guide, i, j);
                let wt = (-(dx * dx + dy * dy) / ss - dn / sn - dz / sz).exp();
                sum += wt;
                for c in 0..3 {
                    acc[c] += wt * input[c][j] as f64;
                }
            }
            for c in 0..3 {
                out[c][i] = (acc[c] / sum) as f32;
            }
        }
    }
    out
}

/// Edge-avoiding À-Trous straight from its definition, in f64.
pub fn atrous_direct(input: [&[f32]; 3], guide: &Guide, p: &AtrousParams) -> [Vec<f32>; 3] {
    const H: [f64; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];
    let (w, h) = (guide.width as i64, guide.height as i64);
    let mut cur: [Vec<f64>; 3] = input.map(|p| p.iter().map(|&v| v as f64).collect());
    let [sn, sz] = [p.sigma_normal, p.sigma_depth].map(|s| f64::from(s).powi(2));
    let unit = crate::atrous::colour_scale(input);
    for it in 0..p.iterations {
        let step = 1i64 << it;
        let sc = (f64::from(p.sigma_colour * unit) / (1u64 << it) as f64).powi(2);
        let mut next: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; (w * h) as usize]);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let (mut sum, mut acc) = (0.0, [0.0; 3]);
                for (ty, hy) in H.iter().enumerate() {
                    for (tx, hx) in H.iter().enumerate() {
                        let (xx, yy) = (x + (tx as i64 - 2) * step, y + (ty as i64 - 2) * step);
                        if xx < 0 || yy < 0 || xx >= w || yy >= h {
                            continue;
                        }
                        let j = (yy * w + xx) as usize;
                        let dc: f64 = (0..3).map(|c| (cur[c][i] - cur[c][j]).powi(2)).sum();
                        let (dn, dz) = geometry_distance(guide, i, j);
                        let wt = hx * hy * (-dc / sc - dn / sn - dz / sz).exp();
                        sum += wt;
                        for c in 0..3 {
                            acc[c] += wt * cur[c][j];
                        }
                    }
                }
                for c in 0..3 {
                    next[c][i] = acc[c] / sum;
                }
            }
        }
        cur = next;
    }
    cur.map(|p| p.into_iter().map(|v| v as f32).collect())
}
