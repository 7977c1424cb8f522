//! Echo synthesis: what the UAV records for each pulse.
//!
//! The BS transmits OFDM symbols back to back (CP first). The UAV's receiver keeps, for every
//! symbol it uses as (part of) a pulse, the N samples of the FFT window that its sync to the
//! direct path selects: the window of symbol m starts `D = floor(R_d f_s / c)` samples after the
//! symbol's useful part leaves the BS (the CP is discarded, as in every OFDM receiver).
//!
//! A path of range R (direct: |BS→UAV|; echo: |BS→obj| + |obj→UAV|) reaches window sample n
//! with the transmitted signal at `x = n − Δ`, `Δ = R f_s / c − D` samples (real-valued). The
//! continuous-time OFDM signal is the rectangular-windowed sum of subcarriers of 3GPP 38.211, so
//! the delayed signal is, exactly, `u_m(x)` while x lies in symbol m's interval [−N_cp, N) and the
//! neighbouring symbol's otherwise:
//! - paths with Δ ∈ (−1, N_cp] stay inside symbol m over the whole window: their delays are
//!   applied exactly in the frequency domain (`X_k e^{−j2πkΔ/N}` per subcarrier), all such paths
//!   summed before one inverse FFT;
//! - other paths (beyond the CP, or early) are split into per-symbol pieces, each computed
//!   exactly by its own inverse FFT.
//!
//! Amplitudes follow the bistatic radar equation (echo) and the Friis equation (direct path),
//! with the receive antenna gain towards the path's arrival direction and the carrier phase
//! `e^{−j2πR/λ}`. Thermal noise is complex white Gaussian with variance `k T0 F f_s` per sample.
//!
//! Motion: [`MotionModel::StopAndHop`] freezes the geometry at the pulse centre;
//! [`MotionModel::IntraPulse`] evaluates it at each symbol's window centre and applies each path's
//! Doppler shift `f_D = v·û / λ` within the window (exactly for split paths, by a Taylor series
//! whose truncation error is below 1e-10 of the path amplitude for in-CP paths).

use std::collections::HashMap;
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use rustfft::num_complex::{Complex32, Complex64};
use rustfft::{Fft, FftPlanner};

use crate::antenna::Antenna;
use crate::config::{MotionModel, RadarConfig};
use crate::error::{RadarError, Result};
use crate::scene::SceneObject;
use crate::track::{dist3, PulseMeta};
use crate::waveform::{Numerology, C_MPS};

/// Which parts of the received signal to synthesise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Components {
    /// The direct path BS → UAV.
    pub direct: bool,
    /// The object echoes.
    pub echoes: bool,
    /// Thermal noise.
    pub noise: bool,
}

impl Components {
    /// Everything.
    pub const ALL: Components = Components {
        direct: true,
        echoes: true,
        noise: true,
    };
}

/// One propagation path within one symbol window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Path {
    /// Complex amplitude at the receiver (√W, carrier phase included).
    pub amp: Complex64,
    /// Delay Δ relative to the window start, samples.
    pub delay_samples: f64,
    /// Doppler shift within the window, Hz (0 under stop-and-hop).
    pub doppler_hz: f64,
}

/// The echo synthesiser for one scene and radar.
pub struct Synthesizer {
    num: Numerology,
    motion: MotionModel,
    antenna: Antenna,
    bs_m: [f64; 3],
    objects: Vec<SceneObject>,
    eirp_w: f64,
    noise_w: f64,
    thermal_noise: bool,
    direct_path: bool,
    seed: u64,
    symbols_per_pulse: usize,
    ifft: Arc<dyn Fft<f64>>,
}

impl std::fmt::Debug for Synthesizer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Synthesizer")
            .field("num", &self.num)
            .field("objects", &self.objects.len())
            .finish_non_exhaustive()
    }
}

/// Phase factor e^{−j2π·frac(x)} of a cycle count x (f64, reduced first for accuracy).
fn cis_cycles(x: f64) -> Complex64 {
    let f = x - x.floor();
    Complex64::from_polar(1.0, -std::f64::consts::TAU * f)
}

impl Synthesizer {
    /// A synthesiser for `objects` seen by `radar` with numerology `num`, BS at `bs_m` (x, y, H_b),
    /// receive antenna `antenna`.
    pub fn new(
        num: Numerology,
        radar: &RadarConfig,
        antenna: Antenna,
        bs_m: [f64; 3],
        objects: Vec<SceneObject>,
    ) -> Result<Self> {
        radar.validate()?;
        if num.fft_size != radar.fft_size || num.cp_samples != radar.cp_samples {
            return Err(RadarError::config(
                "radar.fft_size",
                "numerology and radar config disagree",
            ));
        }
        let ifft = FftPlanner::new().plan_fft_inverse(num.fft_size);
        Ok(Self {
            motion: radar.motion,
            antenna,
            bs_m,
            objects,
            eirp_w: radar.tx_power_w
                * 10f64.powf((radar.tx_gain_dbi - radar.system_loss_db) / 10.0),
            noise_w: radar.noise_power_w(),
            thermal_noise: radar.thermal_noise,
            direct_path: radar.direct_path,
            seed: radar.seed,
            symbols_per_pulse: radar.symbols_per_pulse,
            ifft,
            num,
        })
    }

    /// The numerology.
    pub fn numerology(&self) -> &Numerology {
        &self.num
    }

    /// The scene objects.
    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// Noise variance per complex sample, W.
    pub fn noise_power_w(&self) -> f64 {
        self.noise_w
    }

    /// Complex samples per pulse (symbols per pulse × N).
    pub fn samples_per_pulse(&self) -> usize {
        self.symbols_per_pulse * self.num.fft_size
    }

    /// Received direct-path power for a UAV at `pos` with `heading`, W.
    pub fn direct_power_w(&self, pos: [f64; 3], heading: [f64; 2]) -> f64 {
        let r = dist3(pos, self.bs_m);
        let lam = self.num.wavelength_m();
        let g = self.antenna.gain_towards(pos, heading, self.bs_m);
        self.eirp_w * g * lam * lam / (4.0 * std::f64::consts::PI * r).powi(2)
    }

    /// Received echo power of `obj` for a UAV at `pos` with `heading`, W.
    pub fn echo_power_w(&self, obj: &SceneObject, pos: [f64; 3], heading: [f64; 2]) -> f64 {
        let p = [obj.x_m, obj.y_m, 0.0];
        let rt = dist3(self.bs_m, p);
        let rr = dist3(p, pos);
        let lam = self.num.wavelength_m();
        let g = self.antenna.gain_towards(pos, heading, p);
        let four_pi3 = (4.0 * std::f64::consts::PI).powi(3);
        self.eirp_w * g * obj.rcs_m2 * lam * lam / (four_pi3 * rt * rt * rr * rr)
    }

    /// The paths of one symbol window for a UAV at `pos` moving with `vel`, window delay `d`.
    pub fn paths(
        &self,
        pos: [f64; 3],
        vel: [f64; 3],
        heading: [f64; 2],
        window_delay_samples: i64,
        comps: Components,
    ) -> Vec<Path> {
        let fs = self.num.sample_rate_hz();
        let lam = self.num.wavelength_m();
        let intra = self.motion == MotionModel::IntraPulse;
        let doppler = |p: [f64; 3]| -> f64 {
            if !intra {
                return 0.0;
            }
            let d = [p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            (vel[0] * d[0] + vel[1] * d[1] + vel[2] * d[2]) / (n * lam)
        };
        let d0 = window_delay_samples as f64;
        let mut out = Vec::with_capacity(self.objects.len() + 1);
        if comps.direct && self.direct_path {
            let r = dist3(pos, self.bs_m);
            let p = self.direct_power_w(pos, heading);
            out.push(Path {
                amp: cis_cycles(r / lam) * p.sqrt(),
                delay_samples: r * fs / C_MPS - d0,
                doppler_hz: doppler(self.bs_m),
            });
        }
        if comps.echoes {
            for o in &self.objects {
                let q = [o.x_m, o.y_m, 0.0];
                let r = dist3(self.bs_m, q) + dist3(q, pos);
                let p = self.echo_power_w(o, pos, heading);
                out.push(Path {
                    amp: cis_cycles(r / lam) * Complex64::from_polar(p.sqrt(), o.phase_rad),
                    delay_samples: r * fs / C_MPS - d0,
                    doppler_hz: doppler(q),
                });
            }
        }
        out
    }

    /// Synthesises the window of symbol `m` (N samples) from `paths` into `out` (added).
    /// `data(m)` returns the QAM data of symbol m (None before the BS starts transmitting).
    pub fn synthesize_window(
        &self,
        m: i64,
        paths: &[Path],
        data: &mut dyn FnMut(i64) -> Option<Arc<Vec<Complex32>>>,
        out: &mut [Complex64],
    ) {
        let num = &self.num;
        let n = num.fft_size;
        let ncp = num.cp_samples as f64;
        let ns = num.symbol_samples() as f64;
        let nsc = num.subcarriers;
        let fs = num.sample_rate_hz();
        let scale = 1.0 / (nsc as f64).sqrt();
        let mut spec = vec![Complex64::new(0.0, 0.0); n];
        let centre = n as f64 / 2.0;
        // --- in-CP paths: exact delays in the frequency domain, Taylor series in Doppler.
        let cyc: Vec<&Path> = paths
            .iter()
            .filter(|p| p.delay_samples > -1.0 && p.delay_samples <= ncp)
            .collect();
        if !cyc.is_empty() {
            if let Some(x) = data(m) {
                let xmax = cyc
                    .iter()
                    .map(|p| std::f64::consts::TAU * p.doppler_hz.abs() * centre / fs)
                    .fold(0.0, f64::max);
                let mut terms = 1usize;
                let mut bound = 1.0;
                while terms < 12 {
                    bound *= xmax / terms as f64;
                    if bound < 1e-10 {
                        break;
                    }
                    terms += 1;
                }
                let np = cyc.len();
                // SoA: phasor, step and per-term coefficients of each path.
                let mut ph_re = vec![0.0; np];
                let mut ph_im = vec![0.0; np];
                let mut st_re = vec![0.0; np];
                let mut st_im = vec![0.0; np];
                let mut co_re = vec![0.0; np * terms];
                let mut co_im = vec![0.0; np * terms];
                let k0 = num.subcarrier_index(0) as f64;
                for (j, p) in cyc.iter().enumerate() {
                    let step = Complex64::from_polar(
                        1.0,
                        -std::f64::consts::TAU * p.delay_samples / n as f64,
                    );
                    let start = Complex64::from_polar(
                        1.0,
                        -std::f64::consts::TAU * ((k0 * p.delay_samples / n as f64).fract()),
                    );
                    ph_re[j] = start.re;
                    ph_im[j] = start.im;
                    st_re[j] = step.re;
                    st_im[j] = step.im;
                    let mut c = p.amp;
                    for q in 0..terms {
                        co_re[q * np + j] = c.re;
                        co_im[q * np + j] = c.im;
                        c *= p.doppler_hz / (q + 1) as f64;
                    }
                }
                let mut acc = vec![Complex64::new(0.0, 0.0); nsc * terms];
                for i in 0..nsc {
                    for q in 0..terms {
                        let (cr, ci) = (&co_re[q * np..(q + 1) * np], &co_im[q * np..(q + 1) * np]);
                        let mut sr = 0.0;
                        let mut si = 0.0;
                        for j in 0..np {
                            sr += cr[j] * ph_re[j] - ci[j] * ph_im[j];
                            si += cr[j] * ph_im[j] + ci[j] * ph_re[j];
                        }
                        acc[q * nsc + i] = Complex64::new(sr, si);
                    }
                    for j in 0..np {
                        let r = ph_re[j] * st_re[j] - ph_im[j] * st_im[j];
                        let im = ph_re[j] * st_im[j] + ph_im[j] * st_re[j];
                        ph_re[j] = r;
                        ph_im[j] = im;
                    }
                }
                for q in 0..terms {
                    spec.fill(Complex64::new(0.0, 0.0));
                    for i in 0..nsc {
                        let xv = x[i];
                        spec[num.bin(i)] =
                            Complex64::new(xv.re as f64, xv.im as f64) * acc[q * nsc + i] * scale;
                    }
                    self.ifft.process(&mut spec);
                    if q == 0 {
                        for (o, s) in out.iter_mut().zip(&spec) {
                            *o += *s;
                        }
                    } else {
                        // (j 2π (n − N/2)/f_s)^q
                        for (k, (o, s)) in out.iter_mut().zip(&spec).enumerate() {
                            let t = std::f64::consts::TAU * (k as f64 - centre) / fs;
                            let f = Complex64::new(0.0, t).powu(q as u32);
                            *o += *s * f;
                        }
                    }
                }
            }
        }
        // --- other paths: exact per-symbol pieces.
        for p in paths
            .iter()
            .filter(|p| !(p.delay_samples > -1.0 && p.delay_samples <= ncp))
        {
            let dl = p.delay_samples;
            let j_of = |k: f64| ((k - dl + ncp) / ns).floor() as i64;
            let (j_first, j_last) = (j_of(0.0), j_of((n - 1) as f64));
            for j in j_first..=j_last {
                let lo = ((dl - ncp + j as f64 * ns).ceil().max(0.0)) as usize;
                let hi = ((dl - ncp + (j + 1) as f64 * ns).ceil().min(n as f64)) as usize;
                if lo >= hi {
                    continue;
                }
                let Some(x) = data(m + j) else { continue };
                let d = dl + j as f64 * ns;
                let k0 = num.subcarrier_index(0) as f64;
                let step = Complex64::from_polar(1.0, -std::f64::consts::TAU * d / n as f64);
                let mut ph = Complex64::from_polar(
                    1.0,
                    -std::f64::consts::TAU * ((k0 * d / n as f64).fract()),
                );
                spec.fill(Complex64::new(0.0, 0.0));
                for (i, xv) in x.iter().enumerate() {
                    spec[num.bin(i)] = Complex64::new(xv.re as f64, xv.im as f64) * ph * scale;
                    ph *= step;
                }
                self.ifft.process(&mut spec);
                for k in lo..hi {
                    let dop = if p.doppler_hz != 0.0 {
                        Complex64::from_polar(
                            1.0,
                            std::f64::consts::TAU * p.doppler_hz * (k as f64 - centre) / fs,
                        )
                    } else {
                        Complex64::new(1.0, 0.0)
                    };
                    out[k] += p.amp * spec[k] * dop;
                }
            }
        }
    }

    /// Synthesises one pulse (symbols_per_pulse × N samples, symbol-major) into `out`.
    pub fn synthesize_pulse(
        &self,
        pulse: &PulseMeta,
        comps: Components,
        out: &mut [Complex32],
    ) -> Result<()> {
        let n = self.num.fft_size;
        let s_count = self.symbols_per_pulse;
        if out.len() != s_count * n {
            return Err(RadarError::Shape {
                what: format!("pulse {} buffer", pulse.index),
                expected: format!("{} samples", s_count * n),
                found: format!("{}", out.len()),
            });
        }
        let fs = self.num.sample_rate_hz();
        let ns = self.num.symbol_samples() as f64;
        let mut cache: HashMap<i64, Arc<Vec<Complex32>>> = HashMap::new();
        let num = &self.num;
        let mut data = |m: i64| -> Option<Arc<Vec<Complex32>>> {
            if m < 0 {
                return None;
            }
            Some(
                cache
                    .entry(m)
                    .or_insert_with(|| Arc::new(num.symbol_data(m as u64)))
                    .clone(),
            )
        };
        let mut buf = vec![Complex64::new(0.0, 0.0); n];
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x5EED_0000_0000_0001);
        rng.set_stream(pulse.index as u64);
        let sigma = (self.noise_w / 2.0).sqrt();
        for s in 0..s_count {
            let m = pulse.symbol as i64 + s as i64;
            let (pos, vel) = match self.motion {
                MotionModel::StopAndHop => (pulse.pos_m, pulse.vel_mps),
                MotionModel::IntraPulse => {
                    // window centre of symbol m in BS time, relative to the pulse's reference time
                    let t = (m as f64 * ns
                        + self.num.cp_samples as f64
                        + pulse.window_delay_samples as f64
                        + n as f64 / 2.0)
                        / fs;
                    let dt = t - pulse.t_s;
                    let v = pulse.vel_mps;
                    (
                        [
                            pulse.pos_m[0] + v[0] * dt,
                            pulse.pos_m[1] + v[1] * dt,
                            pulse.pos_m[2] + v[2] * dt,
                        ],
                        v,
                    )
                }
            };
            let paths = self.paths(pos, vel, pulse.heading, pulse.window_delay_samples, comps);
            buf.fill(Complex64::new(0.0, 0.0));
            self.synthesize_window(m, &paths, &mut data, &mut buf);
            let dst = &mut out[s * n..(s + 1) * n];
            if comps.noise && self.thermal_noise {
                for (o, v) in dst.iter_mut().zip(&buf) {
                    let a: f64 = StandardNormal.sample(&mut rng);
                    let b: f64 = StandardNormal.sample(&mut rng);
                    *o = Complex32::new((v.re + sigma * a) as f32, (v.im + sigma * b) as f32);
                }
            } else {
                for (o, v) in dst.iter_mut().zip(&buf) {
                    *o = Complex32::new(v.re as f32, v.im as f32);
                }
            }
        }
        Ok(())
    }

    /// Synthesises a frame of pulses (pulses × samples, row-major), in parallel over pulses.
    pub fn synthesize_frame(
        &self,
        pulses: &[PulseMeta],
        comps: Components,
    ) -> Result<Vec<Complex32>> {
        let spp = self.samples_per_pulse();
        let mut out = vec![Complex32::new(0.0, 0.0); pulses.len() * spp];
        out.par_chunks_mut(spp)
            .zip(pulses.par_iter())
            .try_for_each(|(dst, p)| self.synthesize_pulse(p, comps, dst))?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RadarConfig;

    fn small_radar(motion: MotionModel) -> RadarConfig {
        RadarConfig {
            fft_size: 64,
            cp_samples: 16,
            subcarrier_spacing_hz: 1e6,
            bandwidth_hz: Some(40e6),
            motion,
            ..RadarConfig::default()
        }
    }

    fn synth(motion: MotionModel) -> Synthesizer {
        let r = small_radar(motion);
        let num = Numerology::new(&r, 40e6, 0.1).unwrap();
        let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
        Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![]).unwrap()
    }

    /// Brute force: evaluate the rectangular-windowed continuous OFDM signal at each sample.
    fn brute(s: &Synthesizer, m: i64, paths: &[Path]) -> Vec<Complex64> {
        let num = s.numerology();
        let n = num.fft_size;
        let (ncp, ns) = (num.cp_samples as f64, num.symbol_samples() as f64);
        let fs = num.sample_rate_hz();
        (0..n)
            .map(|k| {
                let mut acc = Complex64::new(0.0, 0.0);
                for p in paths {
                    let x = k as f64 - p.delay_samples;
                    let j = ((x + ncp) / ns).floor();
                    let sym = m + j as i64;
                    if sym < 0 {
                        continue;
                    }
                    let xl = x - j * ns;
                    let data = num.symbol_data(sym as u64);
                    let mut u = Complex64::new(0.0, 0.0);
                    for (i, d) in data.iter().enumerate() {
                        let kk = num.subcarrier_index(i) as f64;
                        u += Complex64::new(d.re as f64, d.im as f64)
                            * Complex64::from_polar(
                                1.0,
                                std::f64::consts::TAU * kk * xl / n as f64,
                            );
                    }
                    u /= (num.subcarriers as f64).sqrt();
                    let dop = Complex64::from_polar(
                        1.0,
                        std::f64::consts::TAU * p.doppler_hz * (k as f64 - n as f64 / 2.0) / fs,
                    );
                    acc += p.amp * u * dop;
                }
                acc
            })
            .collect()
    }

    #[test]
    fn exact_for_in_cp_and_split_paths() {
        for motion in [MotionModel::StopAndHop, MotionModel::IntraPulse] {
            let s = synth(motion);
            let dop = if motion == MotionModel::IntraPulse {
                1.0
            } else {
                0.0
            };
            let paths = vec![
                Path {
                    amp: Complex64::new(1.0, 0.5),
                    delay_samples: 0.37,
                    doppler_hz: 3e3 * dop,
                },
                Path {
                    amp: Complex64::new(-0.2, 0.1),
                    delay_samples: 7.9,
                    doppler_hz: -8e3 * dop,
                },
                Path {
                    amp: Complex64::new(0.3, 0.0),
                    delay_samples: 16.0,
                    doppler_hz: 0.0,
                },
                // beyond the CP: split between symbols m−1 and m
                Path {
                    amp: Complex64::new(0.1, -0.4),
                    delay_samples: 23.6,
                    doppler_hz: 5e3 * dop,
                },
                // more than a symbol late: symbols m−2 and m−1
                Path {
                    amp: Complex64::new(0.05, 0.05),
                    delay_samples: 101.2,
                    doppler_hz: 0.0,
                },
                // early: symbols m and m+1
                Path {
                    amp: Complex64::new(0.2, 0.2),
                    delay_samples: -3.3,
                    doppler_hz: 0.0,
                },
            ];
            let mut data =
                |m: i64| (m >= 0).then(|| Arc::new(s.numerology().symbol_data(m as u64)));
            let mut out = vec![Complex64::new(0.0, 0.0); 64];
            s.synthesize_window(5, &paths, &mut data, &mut out);
            let want = brute(&s, 5, &paths);
            let err: f64 = out.iter().zip(&want).map(|(a, b)| (a - b).norm_sqr()).sum();
            let pow: f64 = want.iter().map(|a| a.norm_sqr()).sum();
            assert!(
                err / pow < 1e-20,
                "{motion:?}: relative error {}",
                err / pow
            );
        }
    }

    #[test]
    fn noise_has_kt0f_fs_variance() {
        let r = RadarConfig::default();
        let num = Numerology::new(&r, 150e6, 0.1).unwrap();
        let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
        let s = Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![]).unwrap();
        let pulse = PulseMeta {
            index: 3,
            aperture: 0,
            look: 0,
            t_s: 1.0,
            symbol: 100,
            pos_m: [0.0, 0.0, 1000.0],
            vel_mps: [0.0, 20.0, 0.0],
            heading: [0.0, 1.0],
            window_delay_samples: 2000,
        };
        let comps = Components {
            direct: false,
            echoes: false,
            noise: true,
        };
        let mut out = vec![Complex32::new(0.0, 0.0); 4096];
        s.synthesize_pulse(&pulse, comps, &mut out).unwrap();
        let p: f64 = out.iter().map(|x| x.norm_sqr() as f64).sum::<f64>() / 4096.0;
        assert!(
            (p / s.noise_power_w() - 1.0).abs() < 0.08,
            "{}",
            p / s.noise_power_w()
        );
    }

    #[test]
    fn radar_equation_amplitudes() {
        let r = RadarConfig::default();
        let num = Numerology::new(&r, 150e6, 0.1).unwrap();
        let ant = Antenna::new(&r, 0.1, std::f64::consts::FRAC_PI_4);
        let obj = SceneObject {
            id: 0,
            x_m: 1000.0,
            y_m: 0.0,
            rcs_m2: 10.0,
            phase_rad: 0.0,
            landmark: None,
        };
        let s = Synthesizer::new(num, &r, ant, [1000.0, -1000.0, 50.0], vec![obj]).unwrap();
        let pos = [0.0, 0.0, 1000.0];
        let heading = [0.0, 1.0];
        // P_r = P_t G_t G_r σ λ² / ((4π)³ R_t² R_r² L)
        let rt = (1000f64.powi(2) + 50f64.powi(2)).sqrt();
        let rr = 2f64.sqrt() * 1000.0;
        let g_r = ant.peak_gain;
        let want = 40.0 * 10f64.powf(1.2) * g_r * 10.0 * 0.01
            / ((4.0 * std::f64::consts::PI).powi(3) * rt * rt * rr * rr);
        let got = s.echo_power_w(&obj, pos, heading);
        assert!((got / want - 1.0).abs() < 1e-6, "{got} vs {want}");
        let paths = s.paths(pos, [0.0, 20.0, 0.0], heading, 0, Components::ALL);
        assert_eq!(paths.len(), 2);
        assert!((paths[1].amp.norm_sqr() / want - 1.0).abs() < 1e-6);
        let fs = 245.76e6;
        assert!((paths[1].delay_samples - (rt + rr) * fs / C_MPS).abs() < 1e-6);
    }
}
