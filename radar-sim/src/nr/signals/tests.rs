//! Tests of the reference signals against the standard's formulas, property by property.

use super::*;
use crate::nr::frame::{CyclicPrefix, TddPattern};
use std::collections::HashSet;

fn frame(mu: u8, prbs: usize) -> FrameStructure {
    FrameStructure::new(
        mu,
        CyclicPrefix::Normal,
        prbs,
        None,
        TddPattern::all_downlink(),
        "radar.nr",
    )
    .unwrap()
}

fn every_slot() -> Periodicity {
    Periodicity {
        period_slots: 1,
        offset_slot: 0,
        length: 1,
    }
}

#[test]
fn ssb_layout() {
    let b = ssb(17, 3).unwrap();
    let count = |kind| b.iter().filter(|r| r.kind == kind).count();
    assert_eq!((count(ReKind::Pss), count(ReKind::Sss)), (127, 127));
    assert_eq!((count(ReKind::PbchDmrs), count(ReKind::Pbch)), (144, 432));
    let cells: HashSet<(usize, usize)> = b.iter().map(|r| (r.k, r.l)).collect();
    assert_eq!(cells.len(), b.len(), "each RE once");
    for r in &b {
        assert!(r.k < 240 && r.l < 4);
        if r.kind == ReKind::PbchDmrs {
            assert_eq!(r.k % 4, 17 % 4);
            assert!((r.value.norm_sqr() - 1.0).abs() < 1e-12);
        }
        if r.l == 2 && matches!(r.kind, ReKind::Pbch | ReKind::PbchDmrs) {
            assert!(r.k < 48 || r.k >= 192, "{r:?}");
        }
    }
    assert!(ssb(1008, 0).is_err() && ssb(0, 8).is_err());
}

#[test]
fn ssb_burst_lands_on_its_symbols() {
    let f = frame(1, 52);
    let cfg = SsbConfig {
        cell_id: 5,
        first_prb: 10,
        count: 4,
        period_ms: 20,
        l_max: 8,
    };
    cfg.validate(&f, "radar.nr").unwrap();
    // Case C: blocks at symbols 2, 8, 16, 22 of the half frame → slot 0: 2..6, 8..12;
    // slot 1: 2..6 (16), 8..12 (22)
    for slot in [0u64, 1] {
        let res = cfg.res_in_slot(&f, slot);
        let pss_symbols: HashSet<usize> = res
            .iter()
            .filter(|r| r.kind == ReKind::Pss)
            .map(|r| r.l)
            .collect();
        assert_eq!(pss_symbols, HashSet::from([2, 8]), "slot {slot}");
        assert!(res.iter().all(|r| (120..360).contains(&r.k)));
    }
    assert!(cfg.res_in_slot(&f, 2).is_empty());
    // 20 ms later (40 slots at μ = 1) again; 10 ms later not
    assert!(!cfg.res_in_slot(&f, 40).is_empty());
    assert!(cfg.res_in_slot(&f, 20).is_empty());
    let bad = SsbConfig {
        first_prb: 40,
        ..cfg.clone()
    };
    assert_eq!(
        bad.validate(&f, "radar.nr").unwrap_err().field,
        "radar.nr.ssb_first_prb"
    );
    let bad = SsbConfig {
        count: 9,
        ..cfg.clone()
    };
    assert_eq!(
        bad.validate(&f, "radar.nr").unwrap_err().field,
        "radar.nr.ssb_count"
    );
    assert_eq!(ssb_candidate_symbols(3).len(), 64);
}

#[test]
fn trs_positions_and_sequence() {
    let f = frame(1, 24);
    let cfg = TrsConfig {
        scrambling_id: 77,
        k0: 1,
        l0: 5,
        period: Periodicity {
            period_slots: 20,
            offset_slot: 3,
            length: 2,
        },
    };
    cfg.validate(&f, "radar.nr").unwrap();
    assert!(cfg.res_in_slot(&f, 2).is_empty() && cfg.res_in_slot(&f, 5).is_empty());
    for slot in [3u64, 4, 23, 24] {
        let res = cfg.res_in_slot(&f, slot);
        assert_eq!(res.len(), 2 * 3 * 24);
        for r in &res {
            assert!(r.l == 5 || r.l == 9);
            assert_eq!(r.k % 4, 1, "density 3: every 4th subcarrier from k0");
        }
        // the sequence of symbol 9 is r(m) of c_init(77, slot, 9)
        let r9 = qpsk_sequence(csi_rs_c_init(77, (slot % 20) as usize, 9, 14), 72);
        let got: Vec<_> = res.iter().filter(|r| r.l == 9).map(|r| r.value).collect();
        assert_eq!(got, r9);
    }
    let bad = TrsConfig { l0: 7, ..cfg };
    assert_eq!(
        bad.validate(&f, "radar.nr").unwrap_err().field,
        "radar.nr.trs_first_symbol"
    );
}

#[test]
fn prs_combs_cover_every_subcarrier_once() {
    let f = frame(2, 24);
    for comb in [2usize, 4, 6, 12] {
        for offset in 0..comb {
            let cfg = PrsConfig {
                sequence_id: 1234,
                comb,
                symbols: 12,
                start_symbol: 1,
                re_offset: offset,
                period: every_slot(),
            };
            cfg.validate(&f, "radar.nr").unwrap();
            let res = cfg.res_in_slot(&f, 7);
            assert_eq!(res.len(), 12 * f.subcarriers() / comb);
            // every group of `comb` consecutive symbols covers each subcarrier exactly once
            for g in 0..12 / comb {
                let mut seen = vec![0usize; f.subcarriers()];
                for r in res.iter().filter(|r| (r.l - 1) / comb == g) {
                    seen[r.k] += 1;
                }
                assert!(seen.iter().all(|&c| c == 1), "comb {comb} offset {offset}");
            }
            // within a symbol: spacing comb, starting at (offset + k') mod comb
            for (j, kp) in prs_offsets(comb).iter().enumerate() {
                let ks: Vec<usize> = res.iter().filter(|r| r.l == 1 + j).map(|r| r.k).collect();
                assert_eq!(ks[0], (offset + kp) % comb);
                assert!(ks.windows(2).all(|w| w[1] - w[0] == comb));
                let want = qpsk_sequence(prs_c_init(1234, 7, 1 + j, 14), ks.len());
                let got: Vec<_> = res
                    .iter()
                    .filter(|r| r.l == 1 + j)
                    .map(|r| r.value)
                    .collect();
                assert_eq!(got, want);
            }
        }
    }
    let base = PrsConfig {
        sequence_id: 0,
        comb: 4,
        symbols: 4,
        start_symbol: 0,
        re_offset: 0,
        period: every_slot(),
    };
    for (cfg, field) in [
        (PrsConfig { comb: 3, ..base }, "radar.nr.prs_comb"),
        (PrsConfig { symbols: 2, ..base }, "radar.nr.prs_symbols"),
        (
            PrsConfig {
                start_symbol: 11,
                ..base
            },
            "radar.nr.prs_start_symbol",
        ),
        (
            PrsConfig {
                re_offset: 4,
                ..base
            },
            "radar.nr.prs_re_offset",
        ),
        (
            PrsConfig {
                sequence_id: 4096,
                ..base
            },
            "radar.nr.prs_sequence_id",
        ),
    ] {
        assert_eq!(cfg.validate(&f, "radar.nr").unwrap_err().field, field);
    }
}

#[test]
fn pdsch_dmrs_positions() {
    let f = frame(0, 10);
    let cfg = PdschDmrsConfig {
        scrambling_id: 300,
        n_scid: 1,
        type_a_position: 2,
        additional_positions: 2,
    };
    cfg.validate("radar.nr").unwrap();
    assert_eq!(cfg.symbols(14), Some(vec![2, 7, 11]));
    assert_eq!(cfg.symbols(10), Some(vec![2, 6, 9]));
    assert_eq!(cfg.symbols(6), Some(vec![2]));
    assert_eq!(cfg.symbols(2), None);
    let a3 = PdschDmrsConfig {
        additional_positions: 3,
        ..cfg
    };
    assert_eq!(a3.symbols(14), Some(vec![2, 5, 8, 11]));
    assert_eq!(a3.symbols(12), Some(vec![2, 5, 8, 11]));
    let a1 = PdschDmrsConfig {
        additional_positions: 1,
        ..cfg
    };
    assert_eq!(a1.symbols(14), Some(vec![2, 11]));
    let res = cfg.res_in_slot(&f, 3, 14, &[1, 4]);
    assert_eq!(res.len(), 3 * 2 * 6);
    for r in &res {
        assert_eq!(r.k % 2, 0);
        assert!((12..24).contains(&r.k) || (48..60).contains(&r.k));
    }
    // PRB 4's values are r(24..30) of the sequence from CRB 0
    let r = qpsk_sequence(pdsch_dmrs_c_init(300, 1, 0, 3, 7, 14), 30);
    let got: Vec<_> = res
        .iter()
        .filter(|x| x.l == 7 && x.k >= 48)
        .map(|x| x.value)
        .collect();
    assert_eq!(got, r[24..30].to_vec());
}

/// TS 38.211 Table 7.4.1.1.2-3 (single-symbol DMRS), PDSCH mapping type A, as the clause prints
/// it: one row per l_d, the columns dmrs-AdditionalPosition 0, 1, 2, 3; `-` where it defines
/// none.
const TABLE_7_4_1_1_2_3_TYPE_A: [&str; 13] = [
    " 2 | -  | -     | -       | -        ",
    " 3 | l0 | l0    | l0      | l0       ",
    " 4 | l0 | l0    | l0      | l0       ",
    " 5 | l0 | l0    | l0      | l0       ",
    " 6 | l0 | l0    | l0      | l0       ",
    " 7 | l0 | l0    | l0      | l0       ",
    " 8 | l0 | l0,7  | l0,7    | l0,7     ",
    " 9 | l0 | l0,7  | l0,7    | l0,7     ",
    "10 | l0 | l0,9  | l0,6,9  | l0,6,9   ",
    "11 | l0 | l0,9  | l0,6,9  | l0,6,9   ",
    "12 | l0 | l0,9  | l0,6,9  | l0,5,8,11",
    "13 | l0 | l0,l1 | l0,7,11 | l0,5,8,11",
    "14 | l0 | l0,l1 | l0,7,11 | l0,5,8,11",
];

#[test]
fn pdsch_dmrs_positions_are_table_7_4_1_1_2_3_cell_by_cell() {
    let mut cells = 0;
    for row in TABLE_7_4_1_1_2_3_TYPE_A {
        let cols: Vec<&str> = row.split('|').map(str::trim).collect();
        let l_d: usize = cols[0].parse().unwrap();
        for l0 in [2usize, 3] {
            for (pos, cell) in cols[1..].iter().enumerate() {
                let mut want: Option<Vec<usize>> = (*cell != "-").then(|| {
                    cell.split(',')
                        .map(|t| match t {
                            "l0" => l0,
                            "l1" => 11, // no lte-CRS-ToMatchAround
                            n => n.parse().unwrap(),
                        })
                        .collect()
                });
                // §7.4.1.1.2: dmrs-AdditionalPosition 3 and l_d = 3 only with l0 = 2
                if l0 == 3 && (pos == 3 || l_d == 3) {
                    want = None;
                }
                let got = pdsch_dmrs_symbols_type_a(l_d, l0, pos);
                assert_eq!(got, want, "l_d = {l_d}, l0 = {l0}, pos{pos}");
                cells += 1;
            }
        }
    }
    assert_eq!(cells, 13 * 4 * 2);
    for l0 in [2, 3] {
        for pos in 0..4 {
            for l_d in [0, 1, 15, 16] {
                assert_eq!(pdsch_dmrs_symbols_type_a(l_d, l0, pos), None);
            }
        }
        assert_eq!(pdsch_dmrs_symbols_type_a(14, l0, 4), None);
    }
    assert_eq!(pdsch_dmrs_symbols_type_a(14, 1, 1), None);
    assert_eq!(pdsch_dmrs_symbols_type_a(14, 4, 1), None);
}

#[test]
fn pdsch_dmrs_refuses_type_a_position_3_with_additional_position_3() {
    let cfg = PdschDmrsConfig {
        scrambling_id: 1,
        n_scid: 0,
        type_a_position: 3,
        additional_positions: 3,
    };
    let e = cfg.validate("radar.nr").unwrap_err();
    assert_eq!(e.field, "radar.nr.dmrs_additional_positions");
    assert!(e.reason.contains("TS 38.211 §7.4.1.1.2"), "{e}");
    for (l0, pos) in [(2, 3), (3, 2), (3, 0)] {
        PdschDmrsConfig {
            type_a_position: l0,
            additional_positions: pos,
            ..cfg
        }
        .validate("radar.nr")
        .unwrap();
    }
}

fn tdd_frame(mu: u8, prbs: usize) -> FrameStructure {
    let tdd = TddPattern::parse("DDDSU", "10:2:2", mu, 14, "p", "s").unwrap();
    FrameStructure::new(mu, CyclicPrefix::Normal, prbs, None, tdd, "radar.nr").unwrap()
}

fn trs(period_slots: u64, offset_slot: u64) -> TrsConfig {
    TrsConfig {
        scrambling_id: 1,
        k0: 0,
        l0: 4,
        period: Periodicity {
            period_slots,
            offset_slot,
            length: 2,
        },
    }
}

#[test]
fn trs_periods_are_those_of_ts_38_214() {
    for mu in 0..=3u8 {
        let f = frame(mu, 24);
        for p in 2..=700u64 {
            let ok = p % (1 << mu) == 0 && [10, 20, 40, 80].contains(&(p >> mu));
            let r = trs(p, 0).validate(&f, "radar.nr");
            assert_eq!(r.is_ok(), ok, "μ = {mu}, {p} slots: {r:?}");
            if let Err(e) = r {
                assert_eq!(e.field, "radar.nr.trs_period_slots");
                assert!(e.reason.contains("TS 38.214 §5.1.6.1.1"), "{e}");
            }
        }
    }
}

#[test]
fn trs_and_prs_stay_in_downlink_symbols() {
    let f = tdd_frame(2, 24);
    // DDDSU: a TRS burst from slot 0, 1 or 2 ends in a D or the special slot's DL symbols
    for offset in 0..3 {
        trs(80, offset).validate(&f, "radar.nr").unwrap();
    }
    for offset in [3, 4] {
        let e = trs(80, offset).validate(&f, "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.trs_offset_slot");
        assert!(e.reason.contains("TS 38.213 §11.1"), "{e}");
    }
    let prs = |start_symbol, offset_slot| PrsConfig {
        sequence_id: 1,
        comb: 4,
        symbols: 4,
        start_symbol,
        re_offset: 0,
        period: Periodicity {
            period_slots: 40,
            offset_slot,
            length: 1,
        },
    };
    prs(10, 2).validate(&f, "radar.nr").unwrap();
    prs(6, 3).validate(&f, "radar.nr").unwrap(); // symbols 6..=9 of the special slot
    for (start, slot) in [(10, 3), (7, 3), (0, 4), (10, 9)] {
        let e = prs(start, slot).validate(&f, "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.prs_period_slots", "{start} {slot}");
        assert!(e.reason.contains("TS 38.213 §11.1"), "{e}");
    }
    // a period that is no multiple of the TDD period walks the PRS into the U slot
    let walking = PrsConfig {
        period: Periodicity {
            period_slots: 16,
            offset_slot: 0,
            length: 1,
        },
        ..prs(0, 0)
    };
    assert!(walking.validate(&f, "radar.nr").is_err());
}

#[test]
fn prs_bandwidth_is_24_to_272_prbs_in_steps_of_4() {
    let cfg = PrsConfig {
        sequence_id: 1,
        comb: 2,
        symbols: 2,
        start_symbol: 0,
        re_offset: 0,
        period: every_slot(),
    };
    for n in 1..=275usize {
        let r = cfg.validate(&frame(1, n), "radar.nr");
        let ok = (24..=272).contains(&n) && n % 4 == 0;
        assert_eq!(r.is_ok(), ok, "{n} PRBs: {r:?}");
        if let Err(e) = r {
            assert_eq!(e.field, "radar.nr.prbs");
            assert!(e.reason.contains("TS 38.211 §7.4.1.7"), "{e}");
        }
    }
}

#[test]
fn i_ssb_bar_carries_the_half_frame_bit_for_l_max_4() {
    // TS 38.211 §7.4.1.4.1
    for i in 0..4 {
        assert_eq!(i_ssb_bar(i, 0, 4), i as u8);
        assert_eq!(i_ssb_bar(i, 1, 4), i as u8 + 4);
    }
    for i in 0..64 {
        for n_hf in 0..2 {
            assert_eq!(i_ssb_bar(i, n_hf, 8), (i % 8) as u8);
            assert_eq!(i_ssb_bar(i, n_hf, 64), (i % 8) as u8);
        }
    }
    // a 5 ms burst at μ = 1: half frame 0 in slots 0..10, half frame 1 in slots 10..20
    let f = frame(1, 52);
    let cfg = SsbConfig {
        cell_id: 5,
        first_prb: 0,
        count: 4,
        period_ms: 5,
        l_max: 4,
    };
    cfg.validate(&f, "radar.nr").unwrap();
    let dmrs = |cfg: &SsbConfig, slot| -> Vec<Complex64> {
        cfg.res_in_slot(&f, slot)
            .into_iter()
            .filter(|r| r.kind == ReKind::PbchDmrs)
            .map(|r| r.value)
            .collect()
    };
    let block = |i_bar| -> Vec<Complex64> {
        ssb(5, i_bar)
            .unwrap()
            .into_iter()
            .filter(|r| r.kind == ReKind::PbchDmrs)
            .map(|r| r.value)
            .collect()
    };
    // slot 0 holds blocks 0 and 1; slot 10 (second half frame) the same blocks with ī + 4
    assert_eq!(dmrs(&cfg, 0), [block(0), block(1)].concat());
    assert_eq!(dmrs(&cfg, 10), [block(4), block(5)].concat());
    assert_eq!(dmrs(&cfg, 20), dmrs(&cfg, 0));
    let l8 = SsbConfig { l_max: 8, ..cfg };
    assert_eq!(dmrs(&l8, 10), dmrs(&l8, 0));
    for (l_max, mu) in [(4, 3), (64, 1), (6, 0)] {
        let bad = SsbConfig {
            l_max,
            ..l8.clone()
        };
        let e = bad.validate(&frame(mu, 52), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.ssb_l_max");
        assert!(e.reason.contains("TS 38.213 §4.1"), "{e}");
    }
    let e = SsbConfig { count: 5, ..cfg }
        .validate(&f, "radar.nr")
        .unwrap_err();
    assert_eq!(e.field, "radar.nr.ssb_count");
}
