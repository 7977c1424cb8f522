//! The f64 reference backprojection and the signal-to-error ratio that the fast kernels are
//! checked with.

use rayon::prelude::*;
use rustfft::num_complex::{Complex32, Complex64};

use super::{check_inputs, BpGeometry, BpPulse};
use crate::error::Result;
use crate::waveform::C_MPS;

/// f64 reference: the same interpolation and phase at arbitrary ground points, all in f64.
pub fn backproject_reference(
    geom: &BpGeometry,
    points: &[[f64; 2]],
    pulses: &[BpPulse],
    profiles: &[Complex32],
    m: usize,
) -> Result<Vec<Complex64>> {
    check_inputs(pulses, profiles, m)?;
    let u = geom.upsample as f64;
    Ok(points
        .par_iter()
        .map(|p| {
            let mut acc = Complex64::new(0.0, 0.0);
            for (n, pl) in pulses.iter().enumerate() {
                let prof = &profiles[n * m..(n + 1) * m];
                let r = geom.bistatic_range_m(*p, pl.pos_m);
                let x = ((r * geom.fs_hz / C_MPS - pl.window_delay_samples as f64) * u
                    - pl.j0 as f64)
                    .clamp(0.0, (m - 2) as f64);
                let k = x.floor() as usize;
                let f = x - k as f64;
                let a = Complex64::new(prof[k].re as f64, prof[k].im as f64);
                let b = Complex64::new(prof[k + 1].re as f64, prof[k + 1].im as f64);
                let v = a + (b - a) * f;
                let cyc = r / geom.wavelength_m;
                acc += v * Complex64::from_polar(
                    pl.weight as f64,
                    std::f64::consts::TAU * (cyc - cyc.floor()),
                );
            }
            acc
        })
        .collect())
}

/// Signal-to-error ratio of `img` against `reference`, dB.
pub fn ser_db(img: &[Complex32], reference: &[Complex64]) -> f64 {
    let mut e = 0.0;
    let mut s = 0.0;
    for (a, b) in img.iter().zip(reference) {
        let a = Complex64::new(a.re as f64, a.im as f64);
        e += (a - b).norm_sqr();
        s += b.norm_sqr();
    }
    10.0 * (s / e).log10()
}
