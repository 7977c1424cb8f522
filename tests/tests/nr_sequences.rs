//! radar_sim::nr against py3gpp (an independent implementation of TS 38.211, in the test
//! environment [`harness::python`]): the Gold sequence c(n) (§5.2.1), PSS (§7.4.2.2.1), SSS
//! (§7.4.2.3.1), the PBCH DMRS and its REs (§7.4.1.4.1, §7.4.3.1) and the PDSCH DMRS (§7.4.1.1),
//! bit for bit (±1 exactly, QPSK to 1e-12). `tests/python/nr/sequences.py` prints py3gpp's.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

use harness::{python, root};
use radar_sim::nr::frame::{CyclicPrefix, FrameStructure, TddPattern};
use radar_sim::nr::sequences::{gold, pbch_dmrs_c_init, pss, qpsk_sequence, sss};
use radar_sim::nr::signals::{ssb, PdschDmrsConfig, ReKind};
use radar_sim::nr::Complex64;
use serde_json::Value;

fn py3gpp() -> Value {
    let out = Command::new(python())
        .arg(root().join("tests/python/nr/sequences.py"))
        .output()
        .expect("running tests/python/nr/sequences.py");
    assert!(
        out.status.success(),
        "sequences.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("sequences.py prints JSON")
}

fn ints(v: &Value) -> Vec<i64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_i64().unwrap())
        .collect()
}

fn complex(v: &Value) -> Vec<(f64, f64)> {
    let re = v["re"].as_array().unwrap();
    let im = v["im"].as_array().unwrap();
    re.iter()
        .zip(im)
        .map(|(a, b)| (a.as_f64().unwrap(), b.as_f64().unwrap()))
        .collect()
}

fn assert_close(what: &str, got: &[Complex64], want: &[(f64, f64)]) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g.re - w.0).abs() < 1e-12 && (g.im - w.1).abs() < 1e-12,
            "{what}: value {i}: {g} vs {w:?}"
        );
    }
}

#[test]
fn nr_sequences_agree_with_py3gpp() {
    let p = py3gpp();

    for case in p["prbs"].as_array().unwrap() {
        let c_init = case["c_init"].as_u64().unwrap() as u32;
        let want: Vec<u8> = ints(&case["bits"]).iter().map(|&b| b as u8).collect();
        assert_eq!(gold(c_init, want.len()), want, "c(n) for c_init {c_init}");
    }

    for (id, want) in p["pss"].as_object().unwrap() {
        let id: u16 = id.parse().unwrap();
        let got: Vec<i64> = pss(id).unwrap().iter().map(|&v| i64::from(v)).collect();
        assert_eq!(got, ints(want), "PSS of N_ID^(2) = {id}");
    }
    let sss_all = p["sss"].as_object().unwrap();
    assert_eq!(sss_all.len(), 1008);
    for (id, want) in sss_all {
        let id: u16 = id.parse().unwrap();
        let got: Vec<i64> = sss(id).unwrap().iter().map(|&v| i64::from(v)).collect();
        assert_eq!(got, ints(want), "SSS of N_ID^cell = {id}");
    }

    for case in p["pbch_dmrs"].as_array().unwrap() {
        let id = case["cell_id"].as_u64().unwrap() as u16;
        let i = case["i_ssb_bar"].as_u64().unwrap() as u8;
        let want = complex(case);
        let seq = qpsk_sequence(pbch_dmrs_c_init(id, i), 144);
        assert_close(&format!("PBCH DMRS {id}/{i}"), &seq, &want);
        // the same values at the block's DMRS REs, in py3gpp's order (k, then l)
        let block: Vec<_> = ssb(id, i)
            .unwrap()
            .into_iter()
            .filter(|r| r.kind == ReKind::PbchDmrs)
            .map(|r| r.value)
            .collect();
        assert_close(&format!("SSB's PBCH DMRS {id}/{i}"), &block, &want);
    }
    for (id, idx) in p["pbch_dmrs_indices"].as_object().unwrap() {
        let id: u16 = id.parse().unwrap();
        let got: Vec<(i64, i64)> = ssb(id, 0)
            .unwrap()
            .into_iter()
            .filter(|r| r.kind == ReKind::PbchDmrs)
            .map(|r| (r.k as i64, r.l as i64))
            .collect();
        let want: Vec<(i64, i64)> = ints(&idx["k"]).into_iter().zip(ints(&idx["l"])).collect();
        assert_eq!(got, want, "PBCH DMRS REs of cell {id}");
    }

    for (mu, case) in p["pdsch_dmrs"].as_array().unwrap().iter().enumerate() {
        let prbs = case["prbs"].as_u64().unwrap() as usize;
        let frame = FrameStructure::new(
            mu as u8,
            CyclicPrefix::Normal,
            prbs,
            None,
            TddPattern::all_downlink(),
            "radar.nr",
        )
        .unwrap();
        let cfg = PdschDmrsConfig {
            scrambling_id: case["scrambling_id"].as_u64().unwrap() as u16,
            n_scid: 0,
            type_a_position: 2,
            additional_positions: case["additional_positions"].as_u64().unwrap() as usize,
        };
        let slot = case["slot"].as_u64().unwrap();
        let all: Vec<usize> = (0..prbs).collect();
        let got: Vec<_> = cfg
            .res_in_slot(&frame, slot, 14, &all)
            .into_iter()
            .map(|r| r.value)
            .collect();
        assert_close(&format!("PDSCH DMRS μ = {mu}"), &got, &complex(case));
    }
}
