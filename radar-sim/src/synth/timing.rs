//! Where the neighbouring symbols of a window lie: symbol m + j's CP start relative to the start
//! of symbol m's useful part, and the phase of its data seen from symbol m's window. Without NR
//! every symbol has N + N_cp samples; under NR each symbol has its own CP (TS 38.211 §5.3.1).

use crate::nr::NrIllumination;

/// The symbol layout around symbol `m`.
pub(super) struct WindowTiming<'a> {
    nr: Option<&'a NrIllumination>,
    m: i64,
    /// Symbol samples with the ordinary CP, N + N_cp.
    ns: f64,
    /// The ordinary CP, N_cp.
    ncp: f64,
    /// Symbol m's useful start from the stream's start (NR only).
    u0: i64,
}

impl<'a> WindowTiming<'a> {
    /// The layout around symbol `m` of `n`-point symbols with CP `ncp` (NR: the cell's own).
    pub(super) fn new(nr: Option<&'a NrIllumination>, m: i64, n: usize, ncp: usize) -> Self {
        let u0 = nr.map_or(0, |ill| {
            let f = &ill.grid.frame;
            f.useful_start_sample(m.max(0) as u64) as i64
        });
        Self {
            nr,
            m,
            ns: (n + ncp) as f64,
            ncp: ncp as f64,
            u0,
        }
    }

    /// Start of symbol m + j's CP relative to symbol m's useful start, samples (NR only; before
    /// the stream's first symbol the ordinary length continues).
    fn nr_start(&self, ill: &NrIllumination, j: i64) -> i64 {
        let f = &ill.grid.frame;
        let mj = self.m + j;
        if mj >= 0 {
            f.symbol_start_sample(mj as u64) as i64 - self.u0
        } else {
            f.symbol_start_sample(0) as i64 + mj * self.ns as i64 - self.u0
        }
    }

    /// The symbol offset j whose interval [CP start, next CP start) holds window position x
    /// (the sample `x` after symbol m's useful start).
    pub(super) fn j_of(&self, x: f64) -> i64 {
        let guess = ((x + self.ncp) / self.ns).floor() as i64;
        let Some(ill) = self.nr else {
            return guess;
        };
        let mut j = guess;
        while (self.nr_start(ill, j + 1) as f64) <= x {
            j += 1;
        }
        while (self.nr_start(ill, j) as f64) > x {
            j -= 1;
        }
        j
    }

    /// The first window sample (unclamped, real) at which a path of delay `d` reaches symbol
    /// m + j1: `d + start(j1)`.
    pub(super) fn change_at(&self, d: f64, j1: i64) -> f64 {
        match self.nr {
            None => d - self.ncp + j1 as f64 * self.ns,
            Some(ill) => d + self.nr_start(ill, j1) as f64,
        }
    }

    /// Symbol m + j's useful start relative to symbol m's, mod `n` (its data's phase ramp in
    /// symbol m's window: e^{−j2πk·offset/N}).
    pub(super) fn phase_offset(&self, j: i64, n: usize, cp_samples: usize) -> i64 {
        match self.nr {
            None => (j * cp_samples as i64).rem_euclid(n as i64),
            Some(ill) => {
                let f = &ill.grid.frame;
                let mj = self.m + j;
                let off = if mj >= 0 {
                    f.useful_start_sample(mj as u64) as i64 - self.u0
                } else {
                    j * self.ns as i64
                };
                off.rem_euclid(n as i64)
            }
        }
    }
}
