//! The standard's sequences: the length-31 Gold sequence c(n) (TS 38.211 §5.2.1), the PSS and
//! SSS m-sequences (§7.4.2.2.1, §7.4.2.3.1), the modulation mapper (§5.1.3–§5.1.6) with its hard
//! decision, and the c_init of each reference signal.

use rustfft::num_complex::Complex64;

use super::{NrError, NrResult};
use crate::config::Modulation;

/// Length of the PSS and SSS, 127.
pub const SYNC_LENGTH: usize = 127;

/// Most physical cell ids: N_ID^cell ∈ 0..=1007 (§7.4.2.1).
pub const MAX_CELL_ID: u16 = 1007;

/// Offset N_c = 1600 of the Gold sequence (§5.2.1).
pub const GOLD_OFFSET: usize = 1600;

const MASK31: u64 = (1 << 31) - 1;

/// The pseudo-random sequence c(n), n = 0..len, of §5.2.1: x1 seeded with 1, x2 with `c_init`
/// (its low 31 bits), c(n) = (x1(n + N_c) + x2(n + N_c)) mod 2.
pub fn gold(c_init: u32, len: usize) -> Vec<u8> {
    // bit i of s holds x(n + i), i = 0..31. Both recursions reach back at most 3 places
    // (x(n + 31) from x(n..=n + 3)), so the next 28 values x(n + 31..n + 59) follow from the
    // state at once: bit i of `s ^ s >> 3` (x1) or `s ^ s >> 1 ^ s >> 2 ^ s >> 3` (x2),
    // i < 28, reads only state bits i..=i + 3 ≤ 30.
    const STRIDE: usize = 28;
    const LOW: u32 = (1 << STRIDE) - 1;
    let mut s1: u32 = 1;
    let mut s2: u32 = c_init & (MASK31 as u32);
    // advances both states by `k` ≤ 28 places
    let advance = |s1: &mut u32, s2: &mut u32, k: usize| {
        let n1 = (*s1 ^ (*s1 >> 3)) & LOW;
        let n2 = (*s2 ^ (*s2 >> 1) ^ (*s2 >> 2) ^ (*s2 >> 3)) & LOW;
        // the state x(n + k..n + k + 31): the old bits k..31, then the new ones
        *s1 = ((*s1 >> k) | (n1 << (31 - k))) & (MASK31 as u32);
        *s2 = ((*s2 >> k) | (n2 << (31 - k))) & (MASK31 as u32);
    };
    let mut skip = GOLD_OFFSET;
    while skip > 0 {
        let k = skip.min(STRIDE);
        advance(&mut s1, &mut s2, k);
        skip -= k;
    }
    let mut out = Vec::with_capacity(len);
    while out.len() < len {
        let k = (len - out.len()).min(STRIDE);
        let c = s1 ^ s2;
        out.extend((0..k).map(|i| ((c >> i) & 1) as u8));
        advance(&mut s1, &mut s2, k);
    }
    out
}

/// QPSK symbols of §5.1.3 from `bits` (pairs): d(i) = ((1 − 2b(2i)) + j(1 − 2b(2i+1))) / √2.
pub fn qpsk(bits: &[u8]) -> Vec<Complex64> {
    let r = std::f64::consts::FRAC_1_SQRT_2;
    bits.chunks_exact(2)
        .map(|b| {
            Complex64::new(
                (1.0 - 2.0 * f64::from(b[0])) * r,
                (1.0 - 2.0 * f64::from(b[1])) * r,
            )
        })
        .collect()
}

/// The QPSK reference sequence r(m) = qpsk(c(2m), c(2m+1)), m = 0..len, for `c_init`.
pub fn qpsk_sequence(c_init: u32, len: usize) -> Vec<Complex64> {
    qpsk(&gold(c_init, 2 * len))
}

/// Levels per axis of `modulation`, √M.
fn levels(modulation: Modulation) -> u32 {
    1 << (modulation.bits() / 2)
}

/// 1 / √(2 (M − 1) / 3): scales an M-QAM alphabet on odd integers to unit mean power (√2, √10,
/// √42, √170 in §5.1).
pub fn qam_scale(modulation: Modulation) -> f64 {
    let m = f64::from(levels(modulation)).powi(2);
    (1.5 / (m - 1.0)).sqrt()
}

/// One axis of §5.1's Gray mapping from its bits (b0, b2, b4, … for I; b1, b3, … for Q):
/// s0 (2^{n−1} − s1 (2^{n−2} − … s_{n−1})), s_i = 1 − 2b_i.
fn axis(bits: impl Iterator<Item = u8>) -> f64 {
    let s: Vec<f64> = bits.map(|b| 1.0 - 2.0 * f64::from(b)).collect();
    let n = s.len();
    let mut t = s.last().copied().unwrap_or(0.0);
    for i in (0..n.saturating_sub(1)).rev() {
        t = s[i] * (f64::from(1u32 << (n - 1 - i)) - t);
    }
    t
}

/// The modulation mapper of §5.1.3–§5.1.6: `bits` (a multiple of the bits per symbol) to unit
/// mean power symbols.
pub fn modulate(modulation: Modulation, bits: &[u8]) -> Vec<Complex64> {
    let q = modulation.bits() as usize;
    let scale = qam_scale(modulation);
    bits.chunks_exact(q)
        .map(|b| {
            let i = axis(b.iter().copied().step_by(2));
            let qv = axis(b.iter().copied().skip(1).step_by(2));
            Complex64::new(i * scale, qv * scale)
        })
        .collect()
}

/// The hard decision on `x` (unit mean power scale): the nearest point of `modulation`'s
/// alphabet, per axis the nearest odd level within ±(√M − 1), rescaled.
pub fn hard_decision(modulation: Modulation, x: Complex64) -> Complex64 {
    let scale = qam_scale(modulation);
    let top = f64::from(levels(modulation) - 1);
    let axis = |v: f64| {
        let level = (2.0 * ((v / scale + top) / 2.0).round() - top).clamp(-top, top);
        level * scale
    };
    Complex64::new(axis(x.re), axis(x.im))
}

/// Checks a physical cell id, naming `field`.
pub fn check_cell_id(cell_id: u16, field: &str) -> NrResult<()> {
    if cell_id > MAX_CELL_ID {
        return Err(NrError::new(
            field,
            format!("{cell_id} must lie in 0..={MAX_CELL_ID}"),
        ));
    }
    Ok(())
}

fn m_sequence(init: [u8; 7], taps: (usize, usize)) -> [u8; SYNC_LENGTH] {
    let mut x = [0u8; SYNC_LENGTH];
    x[..7].copy_from_slice(&init);
    for i in 0..SYNC_LENGTH - 7 {
        x[i + 7] = (x[i + taps.0] + x[i + taps.1]) % 2;
    }
    x
}

/// The PSS d_PSS(n) ∈ {±1} of §7.4.2.2.1 for N_ID^(2) = `cell_id mod 3`: 1 − 2x(m),
/// m = (n + 43 N_ID^(2)) mod 127, x(i + 7) = (x(i + 4) + x(i)) mod 2,
/// [x(6) … x(0)] = [1 1 1 0 1 1 0].
pub fn pss(cell_id: u16) -> NrResult<[i8; SYNC_LENGTH]> {
    check_cell_id(cell_id, "cell_id")?;
    let x = m_sequence([0, 1, 1, 0, 1, 1, 1], (4, 0));
    let shift = 43 * usize::from(cell_id % 3);
    let mut d = [0i8; SYNC_LENGTH];
    for (n, v) in d.iter_mut().enumerate() {
        *v = 1 - 2 * x[(n + shift) % SYNC_LENGTH] as i8;
    }
    Ok(d)
}

/// The SSS d_SSS(n) ∈ {±1} of §7.4.2.3.1: (1 − 2x0((n + m0) mod 127))(1 − 2x1((n + m1) mod 127)),
/// m0 = 15 ⌊N_ID^(1) / 112⌋ + 5 N_ID^(2), m1 = N_ID^(1) mod 112.
pub fn sss(cell_id: u16) -> NrResult<[i8; SYNC_LENGTH]> {
    check_cell_id(cell_id, "cell_id")?;
    let (n1, n2) = (usize::from(cell_id / 3), usize::from(cell_id % 3));
    let m0 = 15 * (n1 / 112) + 5 * n2;
    let m1 = n1 % 112;
    let init = [1, 0, 0, 0, 0, 0, 0];
    let x0 = m_sequence(init, (4, 0));
    let x1 = m_sequence(init, (1, 0));
    let mut d = [0i8; SYNC_LENGTH];
    for (n, v) in d.iter_mut().enumerate() {
        let a = 1 - 2 * x0[(n + m0) % SYNC_LENGTH] as i8;
        let b = 1 - 2 * x1[(n + m1) % SYNC_LENGTH] as i8;
        *v = a * b;
    }
    Ok(d)
}

/// c_init of the PBCH DMRS (§7.4.1.4.1), ī_SSB ∈ 0..8:
/// 2^11 (ī_SSB + 1)(⌊N_ID^cell / 4⌋ + 1) + 2^6 (ī_SSB + 1) + (N_ID^cell mod 4).
pub fn pbch_dmrs_c_init(cell_id: u16, i_ssb_bar: u8) -> u32 {
    let i = u32::from(i_ssb_bar) + 1;
    let c = u32::from(cell_id);
    (1 << 11) * i * (c / 4 + 1) + (1 << 6) * i + c % 4
}

/// c_init of the CSI-RS (§7.4.1.5.2), TRS included:
/// (2^10 (N_symb^slot n_s,f + l + 1)(2 n_ID + 1) + n_ID) mod 2^31.
pub fn csi_rs_c_init(n_id: u16, slot: usize, symbol: usize, symbols_per_slot: usize) -> u32 {
    let t = (symbols_per_slot * slot + symbol + 1) as u64;
    let n = u64::from(n_id);
    (((1u64 << 10) * t * (2 * n + 1) + n) & MASK31) as u32
}

/// c_init of the PRS (§7.4.1.7.2): (2^22 ⌊n_ID^PRS / 1024⌋ + 2^10 (N_symb^slot n_s,f + l + 1)
/// (2 (n_ID^PRS mod 1024) + 1) + (n_ID^PRS mod 1024)) mod 2^31.
pub fn prs_c_init(n_id_prs: u16, slot: usize, symbol: usize, symbols_per_slot: usize) -> u32 {
    let t = (symbols_per_slot * slot + symbol + 1) as u64;
    let hi = u64::from(n_id_prs / 1024);
    let lo = u64::from(n_id_prs % 1024);
    (((1u64 << 22) * hi + (1u64 << 10) * t * (2 * lo + 1) + lo) & MASK31) as u32
}

/// c_init of the PDSCH DMRS (§7.4.1.1.1):
/// (2^17 (N_symb^slot n_s,f + l + 1)(2 N_ID + 1) + 2^17 ⌊λ̄ / 2⌋ + 2 N_ID + n̄_SCID) mod 2^31, with n̄_SCID = 1 − n_SCID for λ̄ = 1 and n_SCID
/// otherwise; `n_id` is the N_ID of that n̄_SCID.
pub fn pdsch_dmrs_c_init(
    n_id: u16,
    n_scid: u8,
    cdm_group: u8,
    slot: usize,
    symbol: usize,
    symbols_per_slot: usize,
) -> u32 {
    let t = (symbols_per_slot * slot + symbol + 1) as u64;
    let n = u64::from(n_id);
    let scid = u64::from(if cdm_group == 1 {
        1 - n_scid.min(1)
    } else {
        n_scid.min(1)
    });
    let lam = u64::from(cdm_group / 2);
    (((1u64 << 17) * t * (2 * n + 1) + (1u64 << 17) * lam + 2 * n + scid) & MASK31) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// c(n) straight from §5.2.1's recursions over whole arrays.
    fn gold_reference(c_init: u32, len: usize) -> Vec<u8> {
        let total = GOLD_OFFSET + len + 31;
        let mut x1 = vec![0u8; total];
        let mut x2 = vec![0u8; total];
        x1[0] = 1;
        for (i, x) in x2.iter_mut().enumerate().take(31) {
            *x = ((c_init >> i) & 1) as u8;
        }
        for n in 0..total - 31 {
            x1[n + 31] = (x1[n + 3] + x1[n]) % 2;
            x2[n + 31] = (x2[n + 3] + x2[n + 2] + x2[n + 1] + x2[n]) % 2;
        }
        (0..len)
            .map(|n| (x1[n + GOLD_OFFSET] + x2[n + GOLD_OFFSET]) % 2)
            .collect()
    }

    #[test]
    fn gold_matches_the_recursion() {
        for c in [0u32, 1, 2, 0x1234_5678 & 0x7FFF_FFFF, (1 << 31) - 1, 45_678] {
            assert_eq!(gold(c, 700), gold_reference(c, 700), "c_init {c}");
        }
        // only the low 31 bits count
        assert_eq!(gold(5 | (1 << 31), 64), gold(5, 64));
        assert_eq!(gold(7, 0).len(), 0);
    }

    #[test]
    fn qam_mapping_is_the_standards() {
        let r = std::f64::consts::FRAC_1_SQRT_2;
        assert_eq!(
            qpsk(&[0, 1, 1, 0]),
            vec![Complex64::new(r, -r), Complex64::new(-r, r)]
        );
        // §5.1.4: bits 0000 → (1 + j)/√10, 0011 → (3 + 3j)/√10, 1111 → (−3 − 3j)/√10
        let s = 10f64.sqrt();
        let d = modulate(Modulation::Qam16, &[0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1]);
        assert!((d[0] - Complex64::new(1.0 / s, 1.0 / s)).norm() < 1e-15);
        assert!((d[1] - Complex64::new(3.0 / s, 3.0 / s)).norm() < 1e-15);
        assert!((d[2] - Complex64::new(-3.0 / s, -3.0 / s)).norm() < 1e-15);
        // §5.1.5: 64-QAM b = 001010 → I: (1)(4 − (−1)(2 − (−1))) = 7, Q: (1)(4 − (1)(2 − 1)) = 3
        let d = modulate(Modulation::Qam64, &[0, 0, 1, 0, 1, 0]);
        let s = 42f64.sqrt();
        assert!(
            (d[0] - Complex64::new(7.0 / s, 3.0 / s)).norm() < 1e-15,
            "{:?}",
            d[0]
        );
        for m in [
            Modulation::Qpsk,
            Modulation::Qam16,
            Modulation::Qam64,
            Modulation::Qam256,
        ] {
            let q = m.bits() as usize;
            let count = 1usize << q;
            let bits: Vec<u8> = (0..count)
                .flat_map(|v| (0..q).map(move |b| ((v >> b) & 1) as u8))
                .collect();
            let d = modulate(m, &bits);
            let p = d.iter().map(|x| x.norm_sqr()).sum::<f64>() / count as f64;
            assert!((p - 1.0).abs() < 1e-12, "{m:?}: {p}");
            // every point distinct, and its own hard decision
            for (i, x) in d.iter().enumerate() {
                assert!((hard_decision(m, *x) - x).norm() < 1e-12);
                assert!(
                    (hard_decision(m, *x * 1.04 + Complex64::new(0.01, -0.01)) - x).norm() < 1e-12
                );
                for y in &d[..i] {
                    assert!((x - y).norm() > 1e-3);
                }
            }
        }
        // far outside: the corner
        let c = hard_decision(Modulation::Qam16, Complex64::new(9.0, -9.0));
        let s = 10f64.sqrt();
        assert!((c - Complex64::new(3.0 / s, -3.0 / s)).norm() < 1e-15);
    }

    #[test]
    fn pss_sss_properties() {
        let p0 = pss(0).unwrap();
        // the three PSS are cyclic shifts by 43
        let p1 = pss(1).unwrap();
        for n in 0..SYNC_LENGTH {
            assert_eq!(p1[n], p0[(n + 43) % SYNC_LENGTH]);
        }
        // an m-sequence: 64 ones (x = 1 ⇒ −1) and 63 zeros
        assert_eq!(p0.iter().filter(|&&v| v == -1).count(), 64);
        // all 1008 SSS distinct
        let all: std::collections::HashSet<[i8; SYNC_LENGTH]> =
            (0..=MAX_CELL_ID).map(|c| sss(c).unwrap()).collect();
        assert_eq!(all.len(), 1008);
        assert!(pss(1008).is_err() && sss(1008).is_err());
    }

    #[test]
    fn c_inits_by_hand() {
        // PBCH DMRS, N_ID = 17, ī = 2: 2048·3·5 + 64·3 + 1
        assert_eq!(pbch_dmrs_c_init(17, 2), 2048 * 3 * 5 + 64 * 3 + 1);
        // CSI-RS, n_ID = 5, slot 3, l = 4, 14 symbols: 1024·(42 + 5)·11 + 5
        assert_eq!(csi_rs_c_init(5, 3, 4, 14), 1024 * 47 * 11 + 5);
        // PRS, n_ID = 2049: ⌊2049/1024⌋ = 2, 2049 mod 1024 = 1; slot 1, l = 2: (14 + 3)·3
        assert_eq!(prs_c_init(2049, 1, 2, 14), (1 << 23) + 1024 * 17 * 3 + 1);
        // wraps mod 2^31: slot 79, l = 13, n_ID = 4095
        let t = 14u64 * 79 + 14;
        let want = ((3u64 << 22) + 1024 * t * 2047 + 1023) % (1 << 31);
        assert_eq!(u64::from(prs_c_init(4095, 79, 13, 14)), want);
        // PDSCH DMRS, N_ID = 10, n_SCID = 1, λ̄ = 0, slot 2, l = 2: 2^17·31·21 + 20 + 1
        assert_eq!(
            u64::from(pdsch_dmrs_c_init(10, 1, 0, 2, 2, 14)),
            (1u64 << 17) * 31 * 21 + 21
        );
        // λ̄ = 1 flips n_SCID; λ̄ = 2 adds 2^17
        assert_eq!(
            pdsch_dmrs_c_init(10, 1, 1, 2, 2, 14),
            pdsch_dmrs_c_init(10, 0, 0, 2, 2, 14)
        );
        assert_eq!(
            u64::from(pdsch_dmrs_c_init(0, 0, 2, 0, 0, 14)),
            (1u64 << 17) + (1 << 17)
        );
    }
}
