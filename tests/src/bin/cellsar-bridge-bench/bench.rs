//! `bench`: every participant as its own process, the paths measured side by side, the table.

use super::*;
use pipeline::certs::ROUTER_ROLE;

pub(super) struct Proc {
    name: String,
    child: Child,
    lines: mpsc::Receiver<String>,
}

impl Proc {
    fn spawn(name: &str, exe: &Path, args: &[String]) -> Result<Proc> {
        let mut child = Command::new(exe)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .with_context(|| format!("starting {name} ({})", exe.display()))?;
        let out: ChildStdout = child
            .stdout
            .take()
            .ok_or_else(|| anyhow!("no stdout of {name}"))?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Proc {
            name: name.to_string(),
            child,
            lines: rx,
        })
    }

    fn expect_line(&self, timeout: Duration) -> Result<String> {
        self.lines
            .recv_timeout(timeout)
            .map_err(|_| anyhow!("{}: no output within {timeout:?}", self.name))
    }

    fn ready(&self) -> Result<()> {
        let l = self.expect_line(Duration::from_secs(30))?;
        if l != "READY" {
            bail!("{}: expected READY, got {l:?}", self.name);
        }
        Ok(())
    }

    fn report<T: for<'de> Deserialize<'de>>(&mut self, timeout: Duration) -> Result<T> {
        let l = self.expect_line(timeout)?;
        let r = serde_json::from_str(&l).with_context(|| format!("{}: report {l:?}", self.name))?;
        let _ = self.child.wait();
        Ok(r)
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            harness::signal(self.child.id(), harness::Signal::SIGTERM);
            let deadline = Instant::now() + Duration::from_secs(5);
            while Instant::now() < deadline {
                if let Ok(Some(_)) = self.child.try_wait() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

pub(super) fn s(v: &str) -> String {
    v.to_string()
}

pub(super) fn free_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

#[derive(Serialize, Clone)]
pub(super) struct BenchRow {
    path: String,
    mode: String,
    frame_mib: usize,
    rep: usize,
    rate_hz: f64,
    tx: TxReport,
    rx: RxReport,
}

pub(super) struct BenchCtx {
    me: PathBuf,
    bridge_exe: PathBuf,
    root: PathBuf,
    max: usize,
    run: usize,
    inbound_queue: usize,
}

/// Zenoh configurations of the bridged path over mutual TLS: bridge B (listens), bridge A and
/// the probe (connect), each with its own certificate of a test CA.
pub(super) struct TlsConfigs {
    b: PathBuf,
    a: PathBuf,
    probe: PathBuf,
}

impl TlsConfigs {
    /// Makes a test CA and the certificates (`cellsar certs`' code) and the three
    /// configurations in `dir`.
    fn make(dir: &Path) -> Result<Self> {
        let certs = dir.join("certs");
        pipeline::certs::make_certs(&pipeline::certs::CertsArgs {
            out: certs.clone(),
            roles: vec![ROUTER_ROLE],
            extra_names: vec![s("bridge-a"), s("bridge-b"), s("probe")],
            hosts: vec![s("127.0.0.1")],
            days: 1,
            force: true,
        })?;
        let ca = certs.join("ca.pem");
        // `role` connects as a client with its own certificate; `listen`, if given, is where it
        // also serves, with the router's (server) certificate. Zenoh's default listener is
        // plain TCP, which a TLS configuration refuses, so every side names its listeners.
        let write = |name: &str, role: &str, listen: &[&str]| -> Result<PathBuf> {
            let path = |p: &Path| serde_json::Value::String(p.display().to_string());
            let server = ROUTER_ROLE;
            let text = format!(
                "{{ mode: 'peer', listen: {{ endpoints: {} }}, transport: {{ link: {{ tls: {{ \
                 root_ca_certificate: {}, listen_private_key: {}, listen_certificate: {}, \
                 connect_private_key: {}, connect_certificate: {}, enable_mtls: true, \
                 verify_name_on_connect: true, close_link_on_expiration: true }} }} }} }}",
                serde_json::to_string(listen)?,
                path(&ca),
                path(&certs.join(format!("{server}.key"))),
                path(&certs.join(format!("{server}.pem"))),
                path(&certs.join(format!("{role}.key"))),
                path(&certs.join(format!("{role}.pem"))),
            );
            let p = dir.join(name);
            std::fs::write(&p, text)?;
            Ok(p)
        };
        Ok(TlsConfigs {
            // bridge B's listener comes from its `-l` flag; bridge A serves too, so that the
            // probe, which meets it through B's gossip, can reach it
            b: write("bridge-b.json5", "bridge-b", &[])?,
            a: write("bridge-a.json5", "bridge-a", &["tls/127.0.0.1:0"])?,
            probe: write("probe.json5", "probe", &[])?,
        })
    }
}

impl BenchCtx {
    fn prefix(&mut self, tag: &str) -> String {
        self.run += 1;
        format!("cb{}_{}_{tag}_", std::process::id(), self.run)
    }

    fn svc(&self, prefix: &str) -> Vec<String> {
        vec![
            s("--service"),
            s("bench/frames"),
            s("--max-frame-bytes"),
            self.max.to_string(),
            s("--iox-root"),
            self.root.display().to_string(),
            s("--iox-prefix"),
            prefix.to_string(),
        ]
    }

    fn timeout(frames: u64, rate: f64) -> Duration {
        let paced = if rate > 0.0 {
            frames as f64 / rate
        } else {
            0.0
        };
        Duration::from_secs_f64(
            (60.0 + 2.0 * paced + frames as f64).min(bridge::flags::MAX_SECONDS),
        )
    }

    /// Producer -> consumer on one iceoryx2 service.
    fn iox(
        &mut self,
        bytes: usize,
        frames: u64,
        rate: f64,
        block: bool,
        spin: bool,
    ) -> Result<(TxReport, RxReport)> {
        let prefix = self.prefix("iox");
        let mut sub_args = vec![s("iox-sub")];
        sub_args.extend(self.svc(&prefix));
        sub_args.extend([s("--frames"), frames.to_string()]);
        if spin {
            sub_args.push(s("--spin"));
        }
        let mut sub = Proc::spawn("iox-sub", &self.me, &sub_args)?;
        sub.ready()?;
        let mut pub_args = vec![s("iox-pub")];
        pub_args.extend(self.svc(&prefix));
        pub_args.extend(tx_args(frames, bytes, rate));
        if block {
            pub_args.push(s("--block"));
        }
        let mut publ = Proc::spawn("iox-pub", &self.me, &pub_args)?;
        publ.ready()?;
        let t = Self::timeout(frames, rate);
        Ok((publ.report(t)?, sub.report(t)?))
    }

    /// Plain Zenoh publisher -> subscriber (two processes, TCP loopback).
    fn zenoh(
        &mut self,
        bytes: usize,
        frames: u64,
        rate: f64,
        key: &str,
    ) -> Result<(TxReport, RxReport)> {
        let port = free_port()?;
        let ep = format!("tcp/127.0.0.1:{port}");
        let mut sub_args = vec![
            s("z-sub"),
            s("--key"),
            s(key),
            s("--frames"),
            frames.to_string(),
            s("--max-frame-bytes"),
            self.max.to_string(),
            s("--no-multicast-scouting"),
            s("-l"),
            ep.clone(),
        ];
        sub_args.push(s("--idle-s"));
        sub_args.push(s("10"));
        let mut sub = Proc::spawn("z-sub", &self.me, &sub_args)?;
        sub.ready()?;
        let mut pub_args = vec![
            s("z-pub"),
            s("--key"),
            s(key),
            s("--wait-matching"),
            s("--no-multicast-scouting"),
            s("-e"),
            ep,
        ];
        pub_args.extend(tx_args(frames, bytes, rate));
        let mut publ = Proc::spawn("z-pub", &self.me, &pub_args)?;
        publ.ready()?;
        let t = Self::timeout(frames, rate);
        Ok((publ.report(t)?, sub.report(t)?))
    }

    /// iceoryx2 producer (host A) -> bridge A -> Zenoh (TCP loopback, or TLS over it with
    /// `tls`) -> bridge B -> iceoryx2 consumer (host B); the "hosts" are two isolated iceoryx2
    /// environments.
    fn bridged(
        &mut self,
        bytes: usize,
        frames: u64,
        rate: f64,
        block: bool,
        key: &str,
        tls: Option<&TlsConfigs>,
    ) -> Result<(TxReport, RxReport)> {
        let port = free_port()?;
        let ep = format!(
            "{}/127.0.0.1:{port}",
            if tls.is_some() { "tls" } else { "tcp" }
        );
        let config = |side: fn(&TlsConfigs) -> &PathBuf| -> Vec<String> {
            tls.map(|t| vec![s("-c"), side(t).display().to_string()])
                .unwrap_or_default()
        };
        let pa = self.prefix("a");
        let pb = self.prefix("b");
        let bridge_args = |instance: &str, prefix: &str, dir: &str, z: &[String]| -> Vec<String> {
            let mut v = vec![
                s("--instance"),
                s(instance),
                s("--service"),
                format!("bench/frames={key}@{dir}"),
                s("--max-frame-bytes"),
                self.max.to_string(),
                s("--iox-root"),
                self.root.display().to_string(),
                s("--iox-prefix"),
                prefix.to_string(),
                s("--no-verify-checksum"),
                s("--stats-interval-s"),
                s("3600"),
                s("--no-multicast-scouting"),
            ];
            v.extend(z.iter().cloned());
            v
        };
        // lossless runs: bridge B waits for the consumer instead of skipping it
        let mut zb = vec![
            s("-l"),
            ep.clone(),
            s("--inbound-queue"),
            self.inbound_queue.to_string(),
        ];
        zb.extend(config(|t| &t.b));
        if block {
            zb.extend([s("--inbound-backpressure"), s("block")]);
        }
        let bb = Proc::spawn(
            "bridge-b",
            &self.bridge_exe,
            &bridge_args("bench-b", &pb, "in", &zb),
        )?;
        let mut sub_args = vec![s("iox-sub")];
        sub_args.extend(self.svc(&pb));
        sub_args.extend([s("--frames"), frames.to_string(), s("--idle-s"), s("10")]);
        let mut sub = Proc::spawn("iox-sub(b)", &self.me, &sub_args)?;
        sub.ready()?;
        let mut za = vec![s("-e"), ep.clone()];
        za.extend(config(|t| &t.a));
        let ba = Proc::spawn(
            "bridge-a",
            &self.bridge_exe,
            &bridge_args("bench-a", &pa, "out", &za),
        )?;
        wait_bridged(&ep, key, Duration::from_secs(30), tls.map(|t| &t.probe))?;
        let mut pub_args = vec![s("iox-pub")];
        pub_args.extend(self.svc(&pa));
        pub_args.extend(tx_args(frames, bytes, rate));
        if block {
            pub_args.push(s("--block"));
        }
        let mut publ = Proc::spawn("iox-pub(a)", &self.me, &pub_args)?;
        publ.ready()?;
        let t = Self::timeout(frames, rate);
        let r = (publ.report(t)?, sub.report(t)?);
        drop(ba);
        drop(bb);
        Ok(r)
    }
}

/// Copies `bytes` from one buffer to another `frames` times (pages touched beforehand).
pub(super) fn memcpy_baseline(bytes: usize, frames: u64) -> (TxReport, RxReport) {
    let src = vec![0x5au8; bytes];
    let mut dst = vec![0u8; bytes];
    dst.copy_from_slice(&src);
    let t = Instant::now();
    for i in 0..frames {
        dst.copy_from_slice(&src);
        std::hint::black_box(&dst[(i as usize * 4096) % bytes]);
    }
    let el = t.elapsed().as_secs_f64();
    let total = bytes as u64 * frames;
    let tp = total as f64 / el / 1e6;
    (
        TxReport {
            frames,
            bytes: total,
            dropped: 0,
            send_errors: 0,
            elapsed_s: el,
            throughput_mb_s: tp,
        },
        RxReport {
            frames,
            bytes: total,
            elapsed_s: el,
            throughput_mb_s: tp,
            lat_us_p50: f64::NAN,
            lat_us_p90: f64::NAN,
            lat_us_p99: f64::NAN,
            lat_us_max: f64::NAN,
            ..RxReport::default()
        },
    )
}

pub(super) fn tx_args(frames: u64, bytes: usize, rate: f64) -> Vec<String> {
    vec![
        s("--frames"),
        frames.to_string(),
        s("--frame-bytes"),
        bytes.to_string(),
        s("--rate-hz"),
        rate.to_string(),
        s("--no-checksum"),
    ]
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub(super) fn bench(args: &BenchArgs) -> Result<()> {
    let (sizes_mib, frames, latency_rate_hz, latency_budget_mb_s) = (
        &args.sizes_mib,
        args.frames,
        args.latency_rate_hz,
        args.latency_budget_mb_s,
    );
    let (repeats, json_out, inbound_queue) = (
        args.repeats.max(1),
        args.json_out.as_deref(),
        args.bridge_inbound_queue,
    );
    let tls_dir = tempfile::tempdir()?;
    let tls = args
        .tls
        .then(|| TlsConfigs::make(tls_dir.path()))
        .transpose()?;
    let me = std::env::current_exe()?;
    let bridge_exe = me.with_file_name("cellsar-bridge");
    if !bridge_exe.exists() {
        bail!("{} not found next to this binary", bridge_exe.display());
    }
    let root = std::env::temp_dir().join(format!("cellsar-bench-{}", std::process::id()));
    std::fs::create_dir_all(&root)?;
    let mut ctx = BenchCtx {
        me,
        bridge_exe,
        root: root.clone(),
        max: sizes_mib.iter().copied().max().unwrap_or(32) << 20,
        run: 0,
        inbound_queue,
    };
    let mut rows: Vec<BenchRow> = Vec::new();
    let push = |rows: &mut Vec<BenchRow>,
                path: &str,
                mode: &str,
                mib: usize,
                rep: usize,
                rate: f64,
                r: (TxReport, RxReport)| {
        eprintln!(
            "{path} {mode} {mib} MiB rep {rep}: tx {:?}\n    rx {:?}",
            r.0, r.1
        );
        rows.push(BenchRow {
            path: s(path),
            mode: s(mode),
            frame_mib: mib,
            rep,
            rate_hz: rate,
            tx: r.0,
            rx: r.1,
        });
    };
    for &mib in sizes_mib {
        let bytes = mib << 20;
        // paced well below the path's capacity so latency is not queueing delay
        let lat_rate = latency_rate_hz.min(latency_budget_mb_s * 1e6 / bytes as f64);
        for rep in 0..repeats {
            if !args.only_network {
                // reference: one process copying the same bytes (the memory bandwidth the
                // iceoryx2 producer's copy into shared memory is bound by)
                let r = memcpy_baseline(bytes, frames);
                push(&mut rows, "memcpy", "throughput", mib, rep, 0.0, r);
                let r = ctx.iox(bytes, frames, lat_rate, false, false)?;
                push(&mut rows, "iceoryx2", "latency", mib, rep, lat_rate, r);
                let r = ctx.iox(bytes, frames, lat_rate, false, true)?;
                push(&mut rows, "iceoryx2", "latency-spin", mib, rep, lat_rate, r);
                let r = ctx.iox(bytes, frames, 0.0, true, false)?;
                push(&mut rows, "iceoryx2", "throughput", mib, rep, 0.0, r);
            }
            // plain Zenoh and the bridged path alternate, so load changes hit both alike
            let key = format!("bench/{mib}/{rep}");
            let r = ctx.zenoh(bytes, frames, lat_rate, &format!("{key}/zl"))?;
            push(&mut rows, "zenoh", "latency", mib, rep, lat_rate, r);
            let r = ctx.bridged(bytes, frames, lat_rate, false, &format!("{key}/bl"), None)?;
            push(&mut rows, "bridge", "latency", mib, rep, lat_rate, r);
            if let Some(t) = &tls {
                let r = ctx.bridged(
                    bytes,
                    frames,
                    lat_rate,
                    false,
                    &format!("{key}/sl"),
                    Some(t),
                )?;
                push(&mut rows, "bridge-tls", "latency", mib, rep, lat_rate, r);
            }
            let r = ctx.zenoh(bytes, frames, 0.0, &format!("{key}/zt"))?;
            push(&mut rows, "zenoh", "throughput", mib, rep, 0.0, r);
            let r = ctx.bridged(bytes, frames, 0.0, true, &format!("{key}/bt"), None)?;
            push(&mut rows, "bridge", "throughput", mib, rep, 0.0, r);
            if let Some(t) = &tls {
                let r = ctx.bridged(bytes, frames, 0.0, true, &format!("{key}/st"), Some(t))?;
                push(&mut rows, "bridge-tls", "throughput", mib, rep, 0.0, r);
            }
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    // iceoryx2 leaves a small management segment per prefix in /dev/shm: remove ours
    let ours = format!("cb{}_", std::process::id());
    if let Ok(rd) = std::fs::read_dir("/dev/shm") {
        for e in rd.flatten() {
            if e.file_name().to_string_lossy().starts_with(&ours) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }

    println!("Medians over {repeats} repetition(s) of {frames} frames each.\n");
    println!("| path | mode | frame | rate | frames rx/tx (all reps) | p50 latency | p90 | p99 | throughput (rx) |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let mut keys: Vec<(String, String, usize)> = Vec::new();
    for r in &rows {
        let k = (r.path.clone(), r.mode.clone(), r.frame_mib);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (path, mode, mib) in &keys {
        let sel: Vec<&BenchRow> = rows
            .iter()
            .filter(|r| &r.path == path && &r.mode == mode && r.frame_mib == *mib)
            .collect();
        let rx: u64 = sel.iter().map(|r| r.rx.frames).sum();
        let tx: u64 = sel.iter().map(|r| r.tx.frames).sum();
        let m = |f: &dyn Fn(&BenchRow) -> f64| median(sel.iter().map(|r| f(r)).collect());
        let rate = sel.first().map(|r| r.rate_hz).unwrap_or(0.0);
        println!(
            "| {path} | {mode} | {mib} MiB | {} | {rx}/{tx} | {:.1} µs | {:.1} µs | {:.1} µs | {:.0} MB/s |",
            if rate > 0.0 { format!("{rate:.1} Hz") } else { s("max") },
            m(&|r| r.rx.lat_us_p50),
            m(&|r| r.rx.lat_us_p90),
            m(&|r| r.rx.lat_us_p99),
            m(&|r| r.rx.throughput_mb_s),
        );
    }
    println!("\n| frame | bridge / plain Zenoh throughput (median of per-repetition ratios) | bridge / plain p50 latency |");
    println!("|---:|---:|---:|");
    for &mib in sizes_mib {
        let pick = |path: &str, mode: &str, rep: usize| {
            rows.iter()
                .find(|r| r.path == path && r.mode == mode && r.frame_mib == mib && r.rep == rep)
        };
        let mut tp = Vec::new();
        let mut lat = Vec::new();
        for rep in 0..repeats {
            if let (Some(b), Some(z)) = (
                pick("bridge", "throughput", rep),
                pick("zenoh", "throughput", rep),
            ) {
                tp.push(b.rx.throughput_mb_s / z.rx.throughput_mb_s);
            }
            if let (Some(b), Some(z)) = (
                pick("bridge", "latency", rep),
                pick("zenoh", "latency", rep),
            ) {
                lat.push(b.rx.lat_us_p50 / z.rx.lat_us_p50);
            }
        }
        println!("| {mib} MiB | {:.3} | {:.3} |", median(tp), median(lat));
    }
    if tls.is_some() {
        ratio_table(&rows, sizes_mib, repeats, ("bridge-tls", "bridge"));
    }
    if let Some(p) = json_out {
        std::fs::write(p, serde_json::to_string_pretty(&rows)?)?;
    }
    Ok(())
}

/// Waits until bridge A's route on `key` is up and sees bridge B's subscriber (its stats say
/// `remote_subscribers`), so no frame is sent before it can be delivered.
pub(super) fn wait_bridged(
    endpoint: &str,
    key: &str,
    timeout: Duration,
    config: Option<&PathBuf>,
) -> Result<()> {
    let args = ZenohArgs {
        config: config.cloned(),
        no_multicast_scouting: true,
        connect: vec![endpoint.to_string()],
        mode: Some(bridge::zconfig::Mode::Peer),
        ..ZenohArgs::default()
    };
    let node = ZenohNode::open(
        args.to_config()?,
        "bench-probe",
        &format!("p{}", std::process::id()),
    )?;
    let stats_key = bridge::keys::bridge_stats("bench-a")?;
    let deadline = Instant::now() + timeout;
    loop {
        let replies = node
            .session()
            .get(&stats_key)
            .timeout(Duration::from_millis(500))
            .wait()
            .map_err(|e| anyhow!("query {stats_key}: {e}"))?;
        let matched = replies.recv().ok().and_then(|r| {
            let sample = r.result().ok()?;
            let v: serde_json::Value = serde_json::from_slice(&sample.payload().to_bytes()).ok()?;
            v["body"]["routes"][0]["remote_subscribers"].as_bool()
        });
        if matched == Some(true) {
            break;
        }
        if Instant::now() > deadline {
            bail!("bridge A did not see a remote subscriber on {key}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    node.close()?;
    Ok(())
}

/// A table of `paths.0` / `paths.1` throughput and p50 latency per frame size (medians of the
/// per-repetition ratios, so that load changes between repetitions cancel).
fn ratio_table(rows: &[BenchRow], sizes_mib: &[usize], repeats: usize, paths: (&str, &str)) {
    let (num, den) = paths;
    println!("\n| frame | {num} / {den} throughput | {num} / {den} p50 latency |");
    println!("|---:|---:|---:|");
    for &mib in sizes_mib {
        let pick = |path: &str, mode: &str, rep: usize| {
            rows.iter()
                .find(|r| r.path == path && r.mode == mode && r.frame_mib == mib && r.rep == rep)
        };
        let (mut tp, mut lat) = (Vec::new(), Vec::new());
        for rep in 0..repeats {
            if let (Some(a), Some(b)) = (pick(num, "throughput", rep), pick(den, "throughput", rep))
            {
                tp.push(a.rx.throughput_mb_s / b.rx.throughput_mb_s);
            }
            if let (Some(a), Some(b)) = (pick(num, "latency", rep), pick(den, "latency", rep)) {
                lat.push(a.rx.lat_us_p50 / b.rx.lat_us_p50);
            }
        }
        println!("| {mib} MiB | {:.3} | {:.3} |", median(tp), median(lat));
    }
}
