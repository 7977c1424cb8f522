//! Which CPU kernels the radar chain runs: the **native** set (the default), chosen at run time
//! by the CPU's features (the hand-written AVX-512 kernels of echo synthesis and
//! backprojection, AVX2+FMA copies of the portable kernels, rustfft's AVX or SSE FFTs), or the
//! **portable** set (plain Rust with no run-time dispatch, rustfft's scalar FFTs), selected for
//! the whole process with the environment variable [`KERNELS_ENV`]`=portable`.
//!
//! The two sets compute the same results to rounding: sums are taken in another order and FFTs
//! factor their length another way, so images differ in their last digits (about 1e-5 relative
//! between the sets, and as much between two CPUs with other features). The portable set gives
//! the same bits on every x86-64 CPU (the system's `libm` aside), and shows without a second
//! machine how far results move when the kernels change: the committed example is checked with
//! both (`tests/tests/example.rs`).

use std::sync::{Arc, OnceLock};

use rustfft::{Fft, FftNum, FftPlanner, FftPlannerScalar};

/// The environment variable that selects the kernel set: `native` (or unset) or `portable`.
pub const KERNELS_ENV: &str = "CELLSAR_KERNELS";

/// A set of CPU kernels (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KernelSet {
    /// The fastest kernels this CPU supports, chosen at run time (the default).
    #[default]
    Native,
    /// Plain Rust kernels and scalar FFTs, the same on every CPU.
    Portable,
}

impl KernelSet {
    /// The set a value of [`KERNELS_ENV`] names (`None`: unset, the native set); an unknown
    /// value is an error that names the variable and the accepted values.
    pub fn from_env_value(value: Option<&str>) -> Result<Self, String> {
        match value.map(str::trim) {
            None | Some("") | Some("native") => Ok(Self::Native),
            Some("portable") => Ok(Self::Portable),
            Some(other) => Err(format!(
                "{KERNELS_ENV}={other:?}: expected \"native\" or \"portable\""
            )),
        }
    }

    /// The set [`KERNELS_ENV`] selects now; an unknown value is an error (see
    /// [`KernelSet::from_env_value`]).
    pub fn from_env() -> Result<Self, String> {
        let value = std::env::var(KERNELS_ENV).ok();
        Self::from_env_value(value.as_deref())
    }
}

/// The kernel set of this process, read from [`KERNELS_ENV`] on first use; an unknown value is
/// logged once and gives the native set (binaries refuse it at start with [`KernelSet::from_env`]).
pub fn selected() -> KernelSet {
    static SET: OnceLock<KernelSet> = OnceLock::new();
    *SET.get_or_init(|| {
        KernelSet::from_env().unwrap_or_else(|e| {
            tracing::warn!("{e}; using the native kernels");
            KernelSet::Native
        })
    })
}

/// Whether the hand-written AVX-512 kernels run: the native set on a CPU with AVX-512F.
pub fn avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        selected() == KernelSet::Native && std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether the AVX2+FMA copies of the portable kernels run: the native set on a CPU with both.
pub fn avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        selected() == KernelSet::Native
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Makes FFTs of the selected set: rustfft's planner (AVX, SSE or NEON by the CPU) for the
/// native set, its scalar planner for the portable one.
pub enum FftMaker<T: FftNum> {
    /// rustfft's [`FftPlanner`].
    Native(FftPlanner<T>),
    /// rustfft's [`FftPlannerScalar`].
    Portable(FftPlannerScalar<T>),
}

impl<T: FftNum> FftMaker<T> {
    /// A planner of the [`selected`] set.
    pub fn new() -> Self {
        match selected() {
            KernelSet::Native => Self::Native(FftPlanner::new()),
            KernelSet::Portable => Self::Portable(FftPlannerScalar::new()),
        }
    }

    /// A forward FFT of `len` points.
    pub fn forward(&mut self, len: usize) -> Arc<dyn Fft<T>> {
        match self {
            Self::Native(p) => p.plan_fft_forward(len),
            Self::Portable(p) => p.plan_fft_forward(len),
        }
    }

    /// An inverse (unnormalised) FFT of `len` points.
    pub fn inverse(&mut self, len: usize) -> Arc<dyn Fft<T>> {
        match self {
            Self::Native(p) => p.plan_fft_inverse(len),
            Self::Portable(p) => p.plan_fft_inverse(len),
        }
    }
}

impl<T: FftNum> Default for FftMaker<T> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_variable_names_a_set_or_is_refused_with_its_name() {
        assert_eq!(KernelSet::from_env_value(None), Ok(KernelSet::Native));
        assert_eq!(KernelSet::from_env_value(Some("")), Ok(KernelSet::Native));
        assert_eq!(
            KernelSet::from_env_value(Some("native")),
            Ok(KernelSet::Native)
        );
        assert_eq!(
            KernelSet::from_env_value(Some(" portable ")),
            Ok(KernelSet::Portable)
        );
        let e = KernelSet::from_env_value(Some("scalar")).unwrap_err();
        assert!(e.contains(KERNELS_ENV) && e.contains("scalar"), "{e}");
    }

    #[test]
    fn both_fft_sets_agree_to_rounding() {
        let n = 4096 + 96; // a mixed-radix length, as the OFDM numerologies use
        let x: Vec<rustfft::num_complex::Complex64> = (0..n)
            .map(|i| {
                rustfft::num_complex::Complex64::new((i as f64 * 0.37).sin(), (i as f64).cos())
            })
            .collect();
        let (mut a, mut b) = (x.clone(), x);
        FftPlanner::new().plan_fft_forward(n).process(&mut a);
        FftPlannerScalar::new().plan_fft_forward(n).process(&mut b);
        let scale = a.iter().map(|v| v.norm()).fold(0.0, f64::max);
        let worst = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        // rounding of an n-point FFT: a few ε·log2(n) of the largest output
        assert!(
            worst <= 64.0 * f64::EPSILON * (n as f64).log2() * scale,
            "{worst} of {scale}"
        );
    }
}
