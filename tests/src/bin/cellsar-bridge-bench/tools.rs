//! The frame tools: publishers and subscribers of frames on iceoryx2 and Zenoh, and the
//! flood of malformed payloads.

use super::*;

pub(super) fn pattern(frame_bytes: usize) -> Result<Vec<Complex32>> {
    if !frame_bytes.is_multiple_of(8) || frame_bytes == 0 {
        bail!("--frame-bytes must be a positive multiple of 8, got {frame_bytes}");
    }
    Ok((0..frame_bytes / 8)
        .map(|i| Complex32::new((i % 1000) as f32, -((i % 777) as f32)))
        .collect())
}

pub(super) fn meta_for(seq: u64, samples: usize) -> Result<FrameMeta> {
    let cols = u32::try_from(samples).context("frame too large")?;
    Ok(FrameMeta::iq(
        MissionId(0xbe7c),
        seq,
        seq as i64 * 1_000_000,
        1,
        cols,
    ))
}

pub(super) struct Pacer {
    start: Instant,
    period: Option<Duration>,
    n: u32,
}

impl Pacer {
    fn new(rate_hz: f64) -> Self {
        Pacer {
            start: Instant::now(),
            period: (rate_hz > 0.0)
                .then(|| Duration::try_from_secs_f64(1.0 / rate_hz).unwrap_or(Duration::MAX)),
            n: 0,
        }
    }
    fn wait(&mut self) {
        if let Some(p) = self.period {
            // checked: an absurdly low rate must not overflow the clock (it is then not paced)
            let due = p
                .checked_mul(self.n)
                .and_then(|d| self.start.checked_add(d));
            let now = Instant::now();
            if let Some(due) = due.filter(|d| *d > now) {
                std::thread::sleep(due - now);
            }
        }
        self.n += 1;
    }
}

pub(super) fn iox_pub(
    svc: &ServiceArgs,
    f: &FrameArgs,
    wait_subscribers: usize,
    block: bool,
) -> Result<()> {
    let env = svc.iox.env()?;
    let (node, _) = FrameNode::new(&env, "bench-iox-pub")?;
    let publisher = node.publisher(
        &svc.spec(),
        FramePublisherOptions {
            checksum: !f.no_checksum,
            backpressure: if block {
                Backpressure::Block
            } else {
                Backpressure::Discard
            },
        },
    )?;
    let samples = pattern(f.frame_bytes)?;
    // A subscriber connects to a new publisher on its next receive or wake-up: wait for the
    // subscribers, then give them that moment, or the first frames find no connection.
    let settle = if wait_subscribers > 0 {
        Duration::from_millis(250)
    } else {
        Duration::ZERO
    };
    if !publisher.wait_for_subscribers(wait_subscribers, Duration::from_secs(20), settle) {
        bail!(
            "no {wait_subscribers} subscriber(s) on {} within 20 s",
            svc.service
        );
    }
    ready();
    let start = Instant::now();
    let mut pacer = Pacer::new(f.rate_hz);
    for seq in 0..f.frames {
        pacer.wait();
        publisher.send_samples(&meta_for(seq, samples.len())?, &samples)?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let c = publisher.counters().snapshot();
    // let the last notifications land before the publisher goes away
    std::thread::sleep(Duration::from_millis(200));
    report(&TxReport {
        frames: c.sent,
        bytes: c.bytes_out,
        dropped: c.dropped,
        send_errors: c.send_errors,
        elapsed_s: elapsed,
        throughput_mb_s: c.bytes_out as f64 / elapsed / 1e6,
    })
}

pub(super) struct RxStats {
    lat_us: Vec<f64>,
    frames: u64,
    bytes: u64,
    checksum_errors: u64,
    first: Option<Instant>,
    last: Option<Instant>,
    last_seq: Option<u64>,
}

impl RxStats {
    fn new() -> Self {
        RxStats {
            lat_us: Vec::new(),
            frames: 0,
            bytes: 0,
            checksum_errors: 0,
            first: None,
            last: None,
            last_seq: None,
        }
    }
    fn on_frame(&mut self, sent_unix_ns: u64, bytes: usize, seq: u64, checksum_ok: bool) {
        let now = now_unix_ns();
        self.lat_us
            .push(now.saturating_sub(sent_unix_ns) as f64 / 1e3);
        self.frames += 1;
        self.bytes += bytes as u64;
        if !checksum_ok {
            self.checksum_errors += 1;
        }
        let t = Instant::now();
        self.first.get_or_insert(t);
        self.last = Some(t);
        self.last_seq = Some(seq);
    }
    /// Enough frames, or out of time.
    fn done(&self, rx: &RxArgs, start: Instant) -> bool {
        self.frames >= rx.frames || start.elapsed() > rx.timeout_s.duration()
    }
    /// Nothing for `idle_s` since the last frame (checked only when nothing is pending).
    fn idle(&self, rx: &RxArgs) -> bool {
        matches!(self.last, Some(l) if l.elapsed() > rx.idle_s.duration())
    }
    fn report(mut self, missed: u64, duplicates: u64, malformed: u64) -> RxReport {
        self.lat_us.sort_by(f64::total_cmp);
        let q = |p: f64| -> f64 {
            if self.lat_us.is_empty() {
                return f64::NAN;
            }
            let i = ((self.lat_us.len() - 1) as f64 * p).round() as usize;
            self.lat_us[i]
        };
        let elapsed = match (self.first, self.last) {
            (Some(a), Some(b)) => (b - a).as_secs_f64(),
            _ => 0.0,
        };
        // throughput over the frames after the first (the first only starts the clock)
        let per_frame = if self.frames > 0 {
            self.bytes as f64 / self.frames as f64
        } else {
            0.0
        };
        let tp = if elapsed > 0.0 && self.frames > 1 {
            per_frame * (self.frames - 1) as f64 / elapsed / 1e6
        } else {
            f64::NAN
        };
        RxReport {
            frames: self.frames,
            bytes: self.bytes,
            missed,
            duplicates,
            malformed,
            checksum_errors: self.checksum_errors,
            last_seq: self.last_seq,
            elapsed_s: elapsed,
            throughput_mb_s: tp,
            lat_us_p50: q(0.5),
            lat_us_p90: q(0.9),
            lat_us_p99: q(0.99),
            lat_us_max: q(1.0),
        }
    }
}

pub(super) fn iox_sub(svc: &ServiceArgs, rx: &RxArgs) -> Result<()> {
    let env = svc.iox.env()?;
    let (node, _) = FrameNode::new(&env, "bench-iox-sub")?;
    let sub = node.subscriber(&svc.spec())?;
    ready();
    let start = Instant::now();
    let mut st = RxStats::new();
    while !st.done(rx, start) {
        match sub.receive()? {
            Some(f) => {
                let ok = !rx.verify || f.verify_checksum().is_ok();
                let h = *f.header();
                st.on_frame(h.time_unix_ns, f.payload().len(), h.seq, ok);
                if rx.hold_ms > 0 {
                    std::thread::sleep(Duration::from_millis(rx.hold_ms));
                }
            }
            None => {
                if st.idle(rx) {
                    break;
                }
                if rx.spin {
                    std::hint::spin_loop();
                } else {
                    sub.wait(Duration::from_millis(50))?;
                }
            }
        }
    }
    let missed = sub.missed();
    let malformed = sub.counters().snapshot().malformed;
    report(&st.report(missed, sub.duplicates(), malformed))
}

pub(super) fn z_node(zenoh: &ZenohArgs, role: &str) -> Result<ZenohNode> {
    let instance = format!("{role}-{}", std::process::id());
    Ok(ZenohNode::open(zenoh.to_config()?, role, &instance)?)
}

pub(super) fn z_pub(
    key: &str,
    f: &FrameArgs,
    wait_matching: bool,
    zenoh: &ZenohArgs,
) -> Result<()> {
    let node = z_node(zenoh, "bench-zpub")?;
    let publisher = node.frame_publisher(key, CongestionControl::Block, Locality::Any)?;
    let samples = pattern(f.frame_bytes)?;
    let payload = frame::samples_as_bytes(&samples);
    let checksum = (!f.no_checksum).then(|| frame::checksum(payload));
    if wait_matching {
        let deadline = Instant::now() + Duration::from_secs(20);
        while !publisher.has_remote_subscribers() {
            if Instant::now() > deadline {
                bail!("no subscriber matched {key} within 20 s");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    ready();
    let start = Instant::now();
    let mut pacer = Pacer::new(f.rate_hz);
    for seq in 0..f.frames {
        pacer.wait();
        let mut h = meta_for(seq, samples.len())?.header(checksum)?;
        h.time_unix_ns = now_unix_ns();
        publisher.put(&h, payload)?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let c = publisher.counters().snapshot();
    std::thread::sleep(Duration::from_millis(200));
    drop(publisher);
    node.close()?;
    report(&TxReport {
        frames: c.sent,
        bytes: c.bytes_out,
        dropped: 0,
        send_errors: c.send_errors,
        elapsed_s: elapsed,
        throughput_mb_s: c.bytes_out as f64 / elapsed / 1e6,
    })
}

pub(super) fn z_sub(
    key: &str,
    max_frame_bytes: usize,
    rx: &RxArgs,
    zenoh: &ZenohArgs,
) -> Result<()> {
    let node = z_node(zenoh, "bench-zsub")?;
    let sub = node.frame_subscriber(
        key,
        FrameSubscribeOptions {
            capacity: 4,
            on_full: OnFull::Block,
            max_payload_bytes: max_frame_bytes,
            verify_checksum: rx.verify,
            allowed_origin: Locality::Any,
        },
    )?;
    ready();
    let start = Instant::now();
    let mut st = RxStats::new();
    let mut tracker = bridge::seq::SeqTracker::new();
    while !st.done(rx, start) {
        // zero copy: the payload stays in Zenoh's buffers (CRC checked there with --verify)
        match sub.recv_frame_timeout(Duration::from_millis(50)) {
            Some(f) => {
                tracker.observe(0, f.header.seq);
                st.on_frame(
                    f.header.time_unix_ns,
                    f.header.payload_len as usize,
                    f.header.seq,
                    true,
                );
                if rx.hold_ms > 0 {
                    std::thread::sleep(Duration::from_millis(rx.hold_ms));
                }
            }
            None if st.idle(rx) => break,
            None => {}
        }
    }
    let c = sub.counters().snapshot();
    let r = st.report(tracker.missing(), tracker.duplicates(), c.malformed);
    drop(sub);
    node.close()?;
    report(&r)
}

/// xorshift64*: a tiny deterministic generator for the flood.
pub(super) struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// One payload that this crate's decoder rejects (checked), of one of several kinds.
pub(super) fn bad_payload(rng: &mut Rng, valid: &[u8], max_frame_bytes: usize, i: u64) -> Vec<u8> {
    loop {
        let p = match i % 5 {
            // random bytes of random length
            0 => {
                let n = rng.below(200) as usize;
                (0..n).map(|_| rng.next() as u8).collect()
            }
            // a valid frame with 1..4 flipped bits anywhere
            1 => {
                let mut v = valid.to_vec();
                for _ in 0..1 + rng.below(4) {
                    let pos = rng.below(v.len() as u64) as usize;
                    v[pos] ^= 1 << rng.below(8);
                }
                v
            }
            // truncated or extended
            2 => {
                let mut v = valid.to_vec();
                if rng.below(2) == 0 {
                    v.truncate(rng.below(v.len() as u64) as usize);
                } else {
                    v.extend((0..1 + rng.below(64)).map(|_| rng.next() as u8));
                }
                v
            }
            // header claiming an oversized payload
            3 => {
                let mut v = valid.to_vec();
                let big = (max_frame_bytes as u64 + 8 + rng.below(1 << 30)) / 8 * 8;
                let cols = (big / 8).min(u64::from(u32::MAX)) as u32;
                v[40..48].copy_from_slice(
                    &(frame::DESCRIPTOR_LEN as u64 + u64::from(cols) * 8).to_le_bytes(),
                );
                let d = bridge::envelope::HEADER_LEN;
                v[d + 8..d + 12].copy_from_slice(&cols.to_le_bytes());
                v
            }
            // wrong magic / version / format / reserved
            _ => {
                let mut v = valid.to_vec();
                let pos =
                    [0usize, 1, 2, 3, 4, 5, 10, 11, 50, 51, 60, 61, 62, 63][rng.below(14) as usize];
                v[pos] = v[pos].wrapping_add(1 + rng.below(250) as u8);
                v
            }
        };
        if frame::decode_wire(&p, max_frame_bytes, true).is_err() {
            return p;
        }
    }
}

pub(super) fn z_flood(
    key: &str,
    count: u64,
    max_frame_bytes: usize,
    seed: u64,
    wait_matching: bool,
    zenoh: &ZenohArgs,
) -> Result<()> {
    let node = z_node(zenoh, "bench-zflood")?;
    let publisher = node.frame_publisher(key, CongestionControl::Block, Locality::Any)?;
    let samples = pattern(4096)?;
    let payload = frame::samples_as_bytes(&samples);
    let valid = frame::encode_wire(
        &meta_for(0, samples.len())?.header(Some(frame::checksum(payload)))?,
        payload,
    )?;
    if wait_matching {
        let deadline = Instant::now() + Duration::from_secs(20);
        while !publisher.has_remote_subscribers() {
            if Instant::now() > deadline {
                bail!("no subscriber matched {key} within 20 s");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    ready();
    let mut rng = Rng(seed.max(1));
    let start = Instant::now();
    let mut oversized_real = 0u64;
    for i in 0..count {
        // two payloads really larger than the limit (the rest only claim to be)
        let p = if i == count / 3 || i == 2 * count / 3 {
            oversized_real += 1;
            vec![0xa5u8; WIRE_PREFIX_LEN + max_frame_bytes + 8]
        } else {
            bad_payload(&mut rng, &valid, max_frame_bytes, i)
        };
        publisher.put_raw(p)?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    std::thread::sleep(Duration::from_millis(300));
    let c = publisher.counters().snapshot();
    drop(publisher);
    node.close()?;
    report(&serde_json::json!({
        "sent": c.sent, "oversized_real": oversized_real, "elapsed_s": elapsed
    }))
}

// ---------------------------------------------------------------------------------------
// The benchmark orchestrator.
