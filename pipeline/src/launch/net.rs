//! The launcher's Zenoh network: its own session and the flags its children get.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use bridge::zconfig::Mode;
use bridge::{ZenohArgs, ZenohNode};

pub(super) struct Net {
    /// The launcher's own flags.
    pub launcher: ZenohArgs,
    /// The flags every child gets.
    pub child: ZenohArgs,
}

pub(super) fn free_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").context("finding a free port")?;
    Ok(l.local_addr().context("finding a free port")?.port())
}

pub(super) fn user_gave_zenoh(z: &ZenohArgs) -> bool {
    z.config.is_some() || z.mode.is_some() || !z.connect.is_empty() || !z.listen.is_empty()
}

/// The Zenoh flags of the children when the user gave the launcher's: the same flags, except
/// that the launcher's own listen endpoints become endpoints every child connects to (on
/// loopback when the launcher listens on every address), and a child that connects to the
/// launcher listens on a free loopback port of its own so that the children find each other
/// (gossip) without multicast scouting. A client launcher cannot listen, and a listen port 0
/// cannot be told to the children: both are refused naming `--listen`.
pub fn children_zenoh(user: &ZenohArgs) -> std::result::Result<ZenohArgs, String> {
    let mut child = user.clone();
    child.listen.clear();
    if user.listen.is_empty() {
        return Ok(child);
    }
    if user.mode == Some(Mode::Client) {
        return Err(format!(
            "--listen {}: a client (-m client) cannot listen; give the router with -e instead",
            user.listen[0]
        ));
    }
    for ep in &user.listen {
        child.connect.push(reachable_endpoint(ep)?);
    }
    // children are peers of the launcher (a router launcher routes for them)
    child.mode = Some(Mode::Peer);
    child.listen.push("tcp/127.0.0.1:0".to_string());
    Ok(child)
}

/// The endpoint a child on this host connects to for a listen endpoint: an unspecified address
/// (`0.0.0.0`, `[::]`) becomes loopback; port 0 is refused (the port is not known in advance).
fn reachable_endpoint(listen: &str) -> std::result::Result<String, String> {
    let (proto, rest) = listen.split_once('/').ok_or_else(|| {
        format!("--listen {listen}: expected PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447")
    })?;
    if proto == "unixsock-stream" {
        return Ok(listen.to_string());
    }
    let (addr, meta) = match rest.split_once(['?', '#']) {
        Some((a, _)) => (a, &rest[a.len()..]),
        None => (rest, ""),
    };
    let (host, port) = addr
        .rsplit_once(':')
        .ok_or_else(|| format!("--listen {listen}: no port"))?;
    if port == "0" {
        return Err(format!(
            "--listen {listen}: port 0 cannot be passed on to the children; give a port"
        ));
    }
    let host = match host {
        "0.0.0.0" => "127.0.0.1",
        "[::]" => "[::1]",
        h => h,
    };
    Ok(format!("{proto}/{host}:{port}{meta}"))
}

/// The roles whose children `--child-config` configures.
const CHILD_ROLES: [&str; 4] = ["planner", "echo", "processor", "bridge"];

/// clap value parser of `--child-config ROLE=FILE`: a child role and a Zenoh configuration
/// file that Zenoh reads (checked now, so that a bad file is refused before anything starts).
pub fn parse_child_config(s: &str) -> std::result::Result<(String, PathBuf), String> {
    let (role, file) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected ROLE=FILE, e.g. echo=deploy/tls/echo.json5"))?;
    if !CHILD_ROLES.contains(&role) {
        return Err(format!(
            "{role:?}: the role must be one of {}",
            CHILD_ROLES.join(", ")
        ));
    }
    let file = PathBuf::from(file);
    ZenohArgs {
        config: Some(file.clone()),
        ..ZenohArgs::default()
    }
    .to_config()
    .map_err(|e| cellsar_error::error_chain(&e))?;
    Ok((role.to_string(), file))
}

/// A child's command line with its Zenoh configuration file replaced by `file` (`--config`
/// added when it had none). The children's Zenoh flags come from [`ZenohArgs::to_cli_args`],
/// which writes the file as `--config FILE`.
pub(super) fn with_child_config(mut args: Vec<String>, file: &Path) -> Vec<String> {
    let file = file.display().to_string();
    match args.iter().position(|a| a == "--config") {
        Some(i) if i + 1 < args.len() => args[i + 1] = file,
        _ => args.extend(["--config".to_string(), file]),
    }
    args
}

/// Opens the launcher's session: an open that fails (a listen endpoint still taken, say) is
/// tried again for 15 s; one that waits (a client whose router is not up yet) waits for as
/// long as it takes. `None` once `stop` is set (SIGINT/SIGTERM), also in the middle of an
/// open ([`ZenohNode::open_until`]).
pub(super) fn open_with_retry(z: &ZenohArgs, stop: &AtomicBool) -> Result<Option<ZenohNode>> {
    let config = z.to_config()?;
    let instance = format!("launcher-{}", std::process::id());
    let deadline = Instant::now() + Duration::from_secs(15);
    loop {
        match ZenohNode::open_until(config.clone(), "launcher", &instance, stop) {
            Ok(n) => return Ok(n),
            Err(_) if stop.load(Ordering::Relaxed) => return Ok(None),
            Err(e) if Instant::now() < deadline => {
                tracing::debug!(error = %e, "opening the Zenoh session; retrying");
                std::thread::sleep(Duration::from_millis(200));
            }
            Err(e) => return Err(e).context("opening the launcher's Zenoh session"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn child_config_replaces_or_adds_the_file() {
        let a = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let f = Path::new("/etc/cellsar/echo.json5");
        assert_eq!(
            with_child_config(a(&["echo", "--config", "l.json5", "--mode", "client"]), f),
            a(&[
                "echo",
                "--config",
                "/etc/cellsar/echo.json5",
                "--mode",
                "client"
            ])
        );
        assert_eq!(
            with_child_config(a(&["echo", "--scene", "s.toml"]), f),
            a(&[
                "echo",
                "--scene",
                "s.toml",
                "--config",
                "/etc/cellsar/echo.json5"
            ])
        );
    }

    #[test]
    fn child_config_flags_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        let ok = dir.path().join("echo.json5");
        std::fs::write(&ok, "{ mode: 'client' }").unwrap();
        let (role, file) = parse_child_config(&format!("echo={}", ok.display())).unwrap();
        assert_eq!((role.as_str(), file.as_path()), ("echo", ok.as_path()));
        assert!(parse_child_config("echo")
            .unwrap_err()
            .contains("ROLE=FILE"));
        assert!(parse_child_config(&format!("router={}", ok.display()))
            .unwrap_err()
            .contains("planner, echo, processor, bridge"));
        let e = parse_child_config("echo=/nonexistent/x.json5").unwrap_err();
        assert!(e.contains("/nonexistent/x.json5"), "{e}");
    }
}
