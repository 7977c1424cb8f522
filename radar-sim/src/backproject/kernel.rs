//! The portable tile kernel: per-tile tables ([`TileSetup`]), per-pulse terms
//! ([`PulseTerms`]) and the inner loop over a tile's pixels, written to auto-vectorise (also
//! compiled for AVX2+FMA and chosen at run time).

use rustfft::num_complex::Complex32;

use super::{BpGeometry, BpPulse, Grid};
use crate::track::dist3;
use crate::waveform::C_MPS;

/// Coefficients of sin(x)/x in powers of x² (Taylor, x = πf ∈ [−π/2, π/2]).
pub(super) const SIN_COEFFS: [f32; 6] = [
    1.0,
    -1.666_666_7e-1,
    8.333_333e-3,
    -1.984_127e-4,
    2.755_731_9e-6,
    -2.505_210_8e-8,
];
/// Coefficients of cos(x) in powers of x² (Taylor, x = πf ∈ [−π/2, π/2]).
pub(super) const COS_COEFFS: [f32; 7] = [
    1.0,
    -0.5,
    4.166_666_8e-2,
    -1.388_888_9e-3,
    2.480_158_7e-5,
    -2.755_732e-7,
    2.087_675_6e-9,
];

/// sin and cos of 2π f for f ∈ [−0.5, 0.5] (half-angle Taylor series, |error| < 2e-7).
#[inline(always)]
pub(super) fn sincos_2pi(f: f32) -> (f32, f32) {
    let x = std::f32::consts::PI * f;
    let x2 = x * x;
    let mut ps = SIN_COEFFS[5];
    for &c in SIN_COEFFS[..5].iter().rev() {
        ps = ps * x2 + c;
    }
    let s = x * ps;
    let mut c = COS_COEFFS[6];
    for &k in COS_COEFFS[..6].iter().rev() {
        c = c * x2 + k;
    }
    (2.0 * s * c, c * c - s * s)
}

/// Everything one tile needs.
pub(super) struct TileJob {
    pub(super) x0: usize,
    pub(super) y0: usize,
    pub(super) w: usize,
    pub(super) h: usize,
}

pub(super) struct Shared<'a> {
    pub(super) geom: &'a BpGeometry,
    pub(super) grid: &'a Grid,
    pub(super) pulses: &'a [BpPulse],
    pub(super) profiles: &'a [Complex32],
    pub(super) m: usize,
}

pub(super) const ROUND_MAGIC: f32 = 12_582_912.0; // 1.5 · 2^23: (x + C) − C rounds to nearest for |x| < 2^22

#[inline(always)]
pub(super) fn tile_kernel(sh: &Shared<'_>, job: &TileJob, out: &mut [Complex32]) {
    let g = sh.grid;
    let geom = sh.geom;
    let (w, h) = (job.w, job.h);
    // tile reference: its centre pixel
    let cx = g.x(job.x0) + (w as f64 - 1.0) / 2.0 * g.spacing_m;
    let cy = g.y(job.y0) + (h as f64 - 1.0) / 2.0 * g.spacing_m;
    let ex: Vec<f64> = (0..w).map(|i| g.x(job.x0 + i) - cx).collect();
    let ey: Vec<f64> = (0..h).map(|j| g.y(job.y0 + j) - cy).collect();
    let bs = geom.bs_m;
    let rtx_ref = dist3(bs, [cx, cy, 0.0]);
    let mut dtx = vec![0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            dtx[j * w + i] = (dist3(bs, [cx + ex[i], cy + ey[j], 0.0]) - rtx_ref) as f32;
        }
    }
    let k_idx = geom.fs_hz / C_MPS * geom.upsample as f64;
    let inv_lam = 1.0 / geom.wavelength_m;
    let mut acc_re = vec![0f32; w * h];
    let mut acc_im = vec![0f32; w * h];
    let mut a = vec![0f32; w];
    let mut idx = vec![0f32; w];
    let mut cyc = vec![0f32; w];
    let mut vr = vec![0f32; w];
    let mut vi = vec![0f32; w];
    let mmax = (sh.m - 2) as f32;
    for (n, p) in sh.pulses.iter().enumerate() {
        let prof = &sh.profiles[n * sh.m..(n + 1) * sh.m];
        let d = [cx - p.pos_m[0], cy - p.pos_m[1], -p.pos_m[2]];
        let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let dn = d2.sqrt();
        let r_ref = rtx_ref + dn;
        let base_idx = ((r_ref * geom.fs_hz / C_MPS - p.window_delay_samples as f64)
            * geom.upsample as f64
            - p.j0 as f64) as f32;
        let base_cyc = {
            let c = r_ref * inv_lam;
            (c - c.floor()) as f32
        };
        for i in 0..w {
            a[i] = (2.0 * d[0] * ex[i] + ex[i] * ex[i]) as f32;
        }
        let (d2f, dnf) = (d2 as f32, dn as f32);
        let (kf, lf, wt) = (k_idx as f32, inv_lam as f32, p.weight);
        for (j, eyj) in ey.iter().enumerate() {
            let b = (2.0 * d[1] * eyj + eyj * eyj) as f32;
            let row = j * w;
            let dt = &dtx[row..row + w];
            // 1: geometry (vectorisable: equal-length zipped slices, no bounds checks)
            for (((x, c), &ai), &dti) in idx[..w]
                .iter_mut()
                .zip(cyc[..w].iter_mut())
                .zip(&a[..w])
                .zip(dt)
            {
                let num = ai + b;
                let s = (d2f + num).sqrt();
                let delta = dti + num / (dnf + s);
                *x = (base_idx + delta * kf).max(0.0).min(mmax);
                let cc = base_cyc + delta * lf;
                *c = cc - ((cc + ROUND_MAGIC) - ROUND_MAGIC);
            }
            // 2: gather + linear interpolation
            for (((&x, r), im), _) in idx[..w]
                .iter()
                .zip(vr[..w].iter_mut())
                .zip(vi[..w].iter_mut())
                .zip(0..w)
            {
                let k = x as i32 as usize;
                let f = x - k as f32;
                if let Some(pp) = prof.get(k..k + 2) {
                    *r = pp[0].re + f * (pp[1].re - pp[0].re);
                    *im = pp[0].im + f * (pp[1].im - pp[0].im);
                }
            }
            // 3: carrier phase and accumulation (vectorisable)
            for ((((ar, ai), &c), &r), &im) in acc_re[row..row + w]
                .iter_mut()
                .zip(acc_im[row..row + w].iter_mut())
                .zip(&cyc[..w])
                .zip(&vr[..w])
                .zip(&vi[..w])
            {
                let (s, co) = sincos_2pi(c);
                *ar += wt * (r * co - im * s);
                *ai += wt * (r * s + im * co);
            }
        }
    }
    for (o, (r, i)) in out.iter_mut().zip(acc_re.iter().zip(&acc_im)) {
        *o = Complex32::new(*r, *i);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) fn tile_kernel_avx2(sh: &Shared<'_>, job: &TileJob, out: &mut [Complex32]) {
    tile_kernel(sh, job, out)
}

pub(super) fn run_tile(sh: &Shared<'_>, job: &TileJob, out: &mut [Complex32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::kernels::avx2_fma() {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            unsafe { tile_kernel_avx2(sh, job, out) };
            return;
        }
    }
    tile_kernel(sh, job, out)
}

/// Per-tile, per-pulse geometry in f32 (computed in f64): the UAV leg of pixel (i, j) is
/// `|d| + num/(|d| + √(|d|² + num))`, `num = 2 d_x e_x + e_x² + 2 d_y e_y + e_y²`, with d the
/// vector UAV → tile reference and e the pixel's offset from the reference.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PulseTerms {
    pub(super) two_dx: f32,
    pub(super) two_dy: f32,
    pub(super) d2: f32,
    pub(super) dn: f32,
    /// Profile position of the tile reference (upsampled samples from j0).
    pub(super) base_idx: f32,
    /// Fractional carrier cycles of the reference's bistatic range.
    pub(super) base_cyc: f32,
    /// Start of this pulse's profile in the weighted copy.
    pub(super) offset: usize,
}

/// Pulse-independent tables of one tile (columns padded to the kernel width).
#[derive(Debug, Clone)]
pub(super) struct TileSetup {
    /// Kernel width (padded columns).
    pub(super) width: usize,
    /// Valid rows.
    pub(super) h: usize,
    /// Column offsets from the reference e_x and their squares (width values).
    pub(super) ex: Vec<f32>,
    pub(super) ex2: Vec<f32>,
    /// Row offsets e_y and their squares (h values).
    pub(super) ey: Vec<f32>,
    pub(super) ey2: Vec<f32>,
    /// BS-leg offsets |BS→p| − |BS→ref| (h × width).
    pub(super) dt: Vec<f32>,
    /// Reference point (x, y), m, and its BS range.
    pub(super) ref_m: [f64; 2],
    pub(super) rtx_ref: f64,
}

impl TileSetup {
    pub(super) fn new(geom: &BpGeometry, grid: &Grid, job: &TileJob, width: usize) -> Self {
        // reference: the centre of the padded tile
        let cx = grid.x(job.x0) + (width as f64 - 1.0) / 2.0 * grid.spacing_m;
        let cy = grid.y(job.y0) + (job.h as f64 - 1.0) / 2.0 * grid.spacing_m;
        let exd: Vec<f64> = (0..width).map(|i| grid.x(job.x0 + i) - cx).collect();
        let eyd: Vec<f64> = (0..job.h).map(|j| grid.y(job.y0 + j) - cy).collect();
        let bs = geom.bs_m;
        let rtx_ref = dist3(bs, [cx, cy, 0.0]);
        let mut dt = Vec::with_capacity(job.h * width);
        for &ey in &eyd {
            for &ex in &exd {
                dt.push((dist3(bs, [cx + ex, cy + ey, 0.0]) - rtx_ref) as f32);
            }
        }
        Self {
            width,
            h: job.h,
            ex: exd.iter().map(|&v| v as f32).collect(),
            ex2: exd.iter().map(|&v| (v * v) as f32).collect(),
            ey: eyd.iter().map(|&v| v as f32).collect(),
            ey2: eyd.iter().map(|&v| (v * v) as f32).collect(),
            dt,
            ref_m: [cx, cy],
            rtx_ref,
        }
    }

    pub(super) fn terms(&self, geom: &BpGeometry, p: &BpPulse, offset: usize) -> PulseTerms {
        let d = [
            self.ref_m[0] - p.pos_m[0],
            self.ref_m[1] - p.pos_m[1],
            -p.pos_m[2],
        ];
        let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let dn = d2.sqrt();
        let r_ref = self.rtx_ref + dn;
        let base_idx = (r_ref * geom.fs_hz / C_MPS - p.window_delay_samples as f64)
            * geom.upsample as f64
            - p.j0 as f64;
        let c = r_ref / geom.wavelength_m;
        PulseTerms {
            two_dx: (2.0 * d[0]) as f32,
            two_dy: (2.0 * d[1]) as f32,
            d2: d2 as f32,
            dn: dn as f32,
            base_idx: base_idx as f32,
            base_cyc: (c - c.floor()) as f32,
            offset,
        }
    }
}
