//! The cost of tagging and verifying IQ frames: the rate of `FrameKey::tag` and
//! `FrameHeader::verify_tag` (keyed BLAKE3) on frames of the IQ services' default size (4 MiB),
//! beside the CRC-32 that every frame already carries.
//!
//! ```text
//! cargo run --release -p bridge --example frame_tag_rate [-- <frames>]
//! ```

use std::time::Instant;

use bridge::frame::{self, FrameKey, FrameMeta, SERVICE_MAX_FRAME_BYTES};
use bridge::{Complex32, MissionId};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: u32 = match std::env::args().nth(1) {
        Some(s) => s.parse().map_err(|e| format!("<frames> {s:?}: {e}"))?,
        None => 200,
    };
    let n = SERVICE_MAX_FRAME_BYTES / 8;
    let samples: Vec<Complex32> = (0..n)
        .map(|i| Complex32::new(i as f32 * 1e-3, -(i as f32) * 2e-3))
        .collect();
    let payload = frame::samples_as_bytes(&samples);
    let key = FrameKey::random()?;
    let meta = FrameMeta::iq(MissionId(1), 0, 0, 1, n as u32);
    let mib = payload.len() as f64 / f64::from(1 << 20);
    let rate = |what: &str, f: &mut dyn FnMut(u64)| {
        let t = Instant::now();
        for i in 0..frames {
            f(u64::from(i));
        }
        let s = t.elapsed().as_secs_f64();
        println!(
            "{what:>12}: {:8.3} ms per {mib} MiB frame, {:7.0} MiB/s",
            s * 1e3 / f64::from(frames),
            mib * f64::from(frames) / s
        );
    };
    let mut sink = 0u64;
    rate("tag", &mut |i| {
        let mut m = meta;
        m.seq = i;
        sink ^= u64::from(key.tag(&m, payload)[0]);
    });
    let header = meta.tagged(&key, payload).header(None)?;
    let mut failures = 0u32;
    rate("verify_tag", &mut |_| {
        failures += u32::from(header.verify_tag(&key, payload).is_err());
    });
    rate("crc32", &mut |_| {
        sink ^= u64::from(frame::checksum(payload))
    });
    if failures > 0 {
        return Err(format!("{failures} verifications failed").into());
    }
    println!("({frames} frames; checksum of the results {sink})");
    Ok(())
}
