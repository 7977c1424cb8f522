//! The launcher's Zenoh network: its own session and the flags its children get.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use bridge::zconfig::{self, Mode, DEFAULT_LISTEN};
use bridge::{NetError, ZenohArgs, ZenohNode};

use super::private::{hub_socket, unix_endpoint};
use crate::protocol::Role;

/// The Zenoh flags of the launcher, of its children and of its router child ([`network`]).
pub struct Net {
    /// The launcher's own flags.
    pub launcher: ZenohArgs,
    /// The flags every child gets.
    pub child: ZenohArgs,
    /// The flags of the router child (`--router`), if any.
    pub router: Option<ZenohArgs>,
    /// On the private mesh (no Zenoh flag, or `--router`): the directory of its Unix sockets,
    /// where every peer child listens on a socket of its own ([`Net::child_listen`]); the
    /// children's flags ([`Net::child`]) then have no listen endpoint.
    pub private_dir: Option<PathBuf>,
}

impl Net {
    /// The flags to add to the command line of the `n`-th child started (`role`): on the
    /// private mesh of peers, `--listen` on a Unix socket of its own in the private directory
    /// (so that the children find each other, and only the user's processes can connect);
    /// nothing otherwise.
    pub fn child_listen(&self, role: Role, n: usize) -> Vec<String> {
        match (&self.private_dir, self.child.mode) {
            (Some(dir), Some(Mode::Peer)) => vec![
                "--listen".to_string(),
                unix_endpoint(&dir.join(format!("{role}-{n}.sock"))),
            ],
            _ => Vec::new(),
        }
    }
}

/// Where the launcher's mesh lives on this host: the loopback TCP port a peer or router
/// launcher listens on when the user gave Zenoh flags but no listen endpoint, and the
/// directory of the private mesh's Unix sockets (no Zenoh flag, or `--router`).
pub struct Hub {
    /// A free loopback TCP port.
    pub tcp_port: u16,
    /// A directory only this user may enter (mode 0700), e.g. a
    /// [`PrivateDir`](super::private::PrivateDir)'s.
    pub private_dir: PathBuf,
}

pub(super) fn free_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").context("finding a free port")?;
    Ok(l.local_addr().context("finding a free port")?.port())
}

/// Whether the user gave the launcher a Zenoh network of their own (a mode, an endpoint, a
/// configuration file or `--multicast-scouting`; `--no-multicast-scouting` and
/// `--zenoh-max-message-bytes` alone keep the isolated mesh, which has no multicast anyway).
fn user_gave_zenoh(z: &ZenohArgs) -> bool {
    z.config.is_some()
        || z.mode.is_some()
        || !z.connect.is_empty()
        || !z.listen.is_empty()
        || z.multicast_scouting
}

/// The Zenoh network of a run, from `--router` and the Zenoh flags; `hub` says where the
/// launcher listens where the user gave it no endpoint. Every combination accepted here forms
/// one mesh of the launcher and its children; one that cannot is refused, naming the flag (the
/// launcher exits 2 before anything starts):
///
/// - no Zenoh flag: the private mesh, the launcher its hub: every process a peer on Unix
///   sockets in `hub.private_dir` (mode 0700, so only the user's own processes connect; the
///   children's sockets: [`Net::child_listen`]);
/// - `--router`: a router child on a Unix socket in `hub.private_dir`, the launcher and every
///   child its clients (refused together with `-m`, `-e`, `-l`, `-c` or
///   `--multicast-scouting`, which it would not use);
/// - a client launcher (`-m client`, or a `-c` file in client mode): every child gets the
///   same flags and is a client of the same routers; refused when it has no router to
///   connect to (no `-e`, no connect endpoint in the file) and multicast scouting is off
///   (the default: without `--multicast-scouting` or a file that turns it on), and with `-l`
///   (a client cannot listen);
/// - a peer or router launcher (also `--multicast-scouting` alone): it is the children's
///   hub. It listens where `-l` (or the `-c` file) says, or, when neither says, on
///   `hub.tcp_port` of loopback; every child is a peer that connects to those endpoints (an
///   unspecified address becomes loopback) and to the launcher's own connect endpoints, and
///   listens on a free loopback port of its own so that the children find each other
///   (gossip) without multicast scouting. A listen endpoint with port 0 is refused (its port
///   cannot be told to the children: Zenoh reports the ports it bound only for non-loopback
///   addresses, in an unstable API). A `-c` file is passed on, so the children keep its
///   other settings.
pub fn network(router: bool, user: &ZenohArgs, hub: &Hub) -> std::result::Result<Net, String> {
    let private = hub_socket(&hub.private_dir);
    let private_dir = Some(hub.private_dir.clone());
    let hub = format!("tcp/127.0.0.1:{}", hub.tcp_port);
    if router {
        if let Some(flag) = zenoh_flag_given(user) {
            return Err(format!(
                "--router with {flag}: the launcher's router child is the whole network (the \
                 launcher and every child its clients); give either --router or Zenoh flags"
            ));
        }
        let client = ZenohArgs {
            mode: Some(Mode::Client),
            connect: vec![private.clone()],
            no_multicast_scouting: true,
            max_message_bytes: user.max_message_bytes,
            ..ZenohArgs::default()
        };
        return Ok(Net {
            launcher: client.clone(),
            child: client,
            router: Some(ZenohArgs {
                max_message_bytes: user.max_message_bytes,
                ..ZenohArgs::isolated(std::slice::from_ref(&private), &[])
            }),
            private_dir,
        });
    }
    if !user_gave_zenoh(user) {
        let with_limit = |z: ZenohArgs| ZenohArgs {
            max_message_bytes: user.max_message_bytes,
            ..z
        };
        // the children listen on sockets of their own (Net::child_listen), added per child
        return Ok(Net {
            launcher: with_limit(ZenohArgs::isolated(std::slice::from_ref(&private), &[])),
            child: with_limit(ZenohArgs::isolated(&[], &[private])),
            router: None,
            private_dir,
        });
    }
    let config = user.to_config().map_err(|e| e.to_string())?;
    let mode = zconfig::effective_mode(&config);
    let connect = zconfig::effective_endpoints(&config, "connect", &mode);
    if mode == "client" {
        if let Some(l) = user.listen.first() {
            return Err(format!(
                "--listen {l}: a client (-m client) cannot listen; give the router with -e instead"
            ));
        }
        let scouting = config.get_json(zconfig::MULTICAST_SCOUTING_KEY).ok();
        if connect.is_empty() && scouting.as_deref() != Some("true") {
            return Err(format!(
                "{}: a client with no router to connect to and multicast scouting off (the \
                 default) never joins a network; give the router with -e ROUTER (or connect \
                 endpoints in the -c file), or find it with --multicast-scouting",
                client_source(user)
            ));
        }
        return Ok(Net {
            launcher: user.clone(),
            child: user.clone(),
            router: None,
            private_dir: None,
        });
    }
    // a peer or router launcher: the children's hub
    if let Some(why) = user.secured_by().map_err(|e| e.to_string())? {
        let source = match (user.mode, &user.config) {
            (Some(m), _) => format!("-m {}", m.as_str()),
            (None, f) => format!(
                "-c {} (mode {mode})",
                f.as_ref()
                    .map(|f| f.display().to_string())
                    .unwrap_or_default()
            ),
        };
        return Err(format!(
            "{source}: with {why}, the launcher and its children must be clients of the router \
             (mode client): a peer or router launcher gives every child a plain loopback \
             listener, and the roles' certificates cannot serve"
        ));
    }
    let mut launcher = user.clone();
    let listen: Vec<(String, String)> = if !user.listen.is_empty() {
        user.listen
            .iter()
            .map(|l| (l.clone(), format!("--listen {l}")))
            .collect()
    } else if user.config.is_some() && file_sets_listen(&config) {
        let file = user
            .config
            .as_ref()
            .map(|f| f.display().to_string())
            .unwrap_or_default();
        zconfig::effective_endpoints(&config, "listen", &mode)
            .into_iter()
            .map(|l| (l.clone(), format!("-c {file}: listen endpoint {l}")))
            .collect()
    } else {
        launcher.listen = vec![hub.clone()];
        vec![(hub.clone(), format!("--listen {hub}"))]
    };
    let mut child = user.clone();
    child.mode = Some(Mode::Peer);
    child.connect = connect;
    for (ep, source) in &listen {
        let reachable = reachable_endpoint(ep, source)?;
        if !child.connect.contains(&reachable) {
            child.connect.push(reachable);
        }
    }
    // children are peers of the launcher (a router launcher routes for them)
    child.listen = vec![DEFAULT_LISTEN.to_string()];
    Ok(Net {
        launcher,
        child,
        router: None,
        private_dir: None,
    })
}

/// The first of `-c`, `-m`, `-e`, `-l`, `--multicast-scouting` given, as the user wrote it.
fn zenoh_flag_given(z: &ZenohArgs) -> Option<String> {
    if let Some(c) = &z.config {
        Some(format!("-c {}", c.display()))
    } else if let Some(m) = z.mode {
        Some(format!("-m {}", m.as_str()))
    } else if let Some(e) = z.connect.first() {
        Some(format!("-e {e}"))
    } else if let Some(l) = z.listen.first() {
        Some(format!("-l {l}"))
    } else {
        z.multicast_scouting
            .then(|| "--multicast-scouting".to_string())
    }
}

/// What made the launcher a client: `-m client`, or the `-c` file.
fn client_source(z: &ZenohArgs) -> String {
    match (&z.mode, &z.config) {
        (Some(Mode::Client), _) | (_, None) => "-m client".to_string(),
        (_, Some(f)) => format!("-c {} (mode client)", f.display()),
    }
}

/// Whether a configuration file set listen endpoints of its own (Zenoh's default listens on
/// every address at a port of its choice, which the children could not be told).
fn file_sets_listen(config: &bridge::zenoh::Config) -> bool {
    let default = bridge::zenoh::Config::default()
        .get_json("listen/endpoints")
        .ok();
    config.get_json("listen/endpoints").ok() != default
}

/// The endpoint a child on this host connects to for a listen endpoint: an unspecified address
/// (`0.0.0.0`, `[::]`) becomes loopback; port 0 is refused (the port is not known in advance),
/// naming `source` (the flag or the file's entry).
fn reachable_endpoint(listen: &str, source: &str) -> std::result::Result<String, String> {
    let (proto, rest) = listen
        .split_once('/')
        .ok_or_else(|| format!("{source}: expected PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447"))?;
    if proto == "unixsock-stream" {
        return Ok(listen.to_string());
    }
    let (addr, meta) = match rest.split_once(['?', '#']) {
        Some((a, _)) => (a, &rest[a.len()..]),
        None => (rest, ""),
    };
    let (host, port) = addr
        .rsplit_once(':')
        .ok_or_else(|| format!("{source}: no port"))?;
    if port == "0" {
        return Err(format!(
            "{source}: port 0 cannot be passed on to the children; give a port"
        ));
    }
    let host = match host {
        "0.0.0.0" => "127.0.0.1",
        "[::]" => "[::1]",
        h => h,
    };
    Ok(format!("{proto}/{host}:{port}{meta}"))
}

/// clap value parser of `--child-config ROLE=FILE`: a child role and a Zenoh configuration
/// file that Zenoh reads (checked now, so that a bad file is refused before anything starts).
pub fn parse_child_config(s: &str) -> std::result::Result<(Role, PathBuf), String> {
    let (name, file) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected ROLE=FILE, e.g. echo=deploy/tls/echo.json5"))?;
    let role = name
        .parse::<Role>()
        .ok()
        .filter(|r| r.is_child())
        .ok_or_else(|| {
            let names: Vec<&str> = Role::CHILDREN.iter().map(|r| r.as_str()).collect();
            format!("{name:?}: the role must be one of {}", names.join(", "))
        })?;
    let file = PathBuf::from(file);
    ZenohArgs {
        config: Some(file.clone()),
        ..ZenohArgs::default()
    }
    .to_config()
    .map_err(|e| cellsar_error::error_chain(&e))?;
    Ok((role, file))
}

/// In a run whose `-c` file enables TLS or access control, every child the launcher starts
/// (`started`) must present its own role's certificate: it needs its own `--child-config`, a
/// file that enables TLS or access control too and that the children's flags (`child`, the
/// launcher's with that file) keep so. Refused otherwise, naming the role and the flag. A run
/// without such a file is not checked.
pub fn check_secure_children(
    user: &ZenohArgs,
    child: &ZenohArgs,
    started: &[Role],
    child_config: &[(Role, PathBuf)],
) -> std::result::Result<(), String> {
    let Some(why) = user.secured_by().map_err(|e| e.to_string())? else {
        return Ok(());
    };
    let launcher_file = user
        .config
        .as_ref()
        .map(|f| f.display().to_string())
        .unwrap_or_default();
    for role in started {
        let Some((_, file)) = child_config.iter().find(|(r, _)| r == role) else {
            return Err(format!(
                "--child-config {role}=FILE missing: -c {launcher_file} enables {why}, and the \
                 {role} would run with the launcher's configuration and certificate; give the \
                 {role} its own (--child-config {role}=FILE) or run it elsewhere (--external \
                 {role})"
            ));
        };
        let own = ZenohArgs {
            config: Some(file.clone()),
            ..child.clone()
        };
        let flag = format!("--child-config {role}={}", file.display());
        if own.secured_by().map_err(|e| e.to_string())?.is_none() {
            return Err(format!(
                "{flag}: enables neither TLS nor access control, while -c {launcher_file} \
                 enables {why}"
            ));
        }
        own.to_config()
            .map_err(|e| format!("{flag}: {}", cellsar_error::error_chain(&e)))?;
    }
    Ok(())
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

/// Opens the launcher's session within `limit` (`--peer-timeout-s`): an open that fails (a
/// listen endpoint still taken, a client whose router does not answer) is tried again, one
/// that waits (a client configured to wait for its router) waits; either says so in the
/// log from the first failure or from 2 s on, naming the session's endpoints, and gives up
/// at `limit` with an error naming them. `None` once `stop` is set (SIGINT/SIGTERM), also in
/// the middle of an open ([`ZenohNode::open_within`]).
pub(super) fn open_with_retry(
    z: &ZenohArgs,
    stop: &AtomicBool,
    limit: Duration,
) -> Result<Option<ZenohNode>> {
    let config = z.to_config()?;
    let described = zconfig::describe(&config);
    let instance = format!("launcher-{}", std::process::id());
    let started = Instant::now();
    let deadline = started.checked_add(limit);
    let mut notice_at = started;
    let gave_up = || {
        anyhow::anyhow!(
            "no Zenoh router or peer reachable within --peer-timeout-s {} s: the launcher's \
             session ({described}) did not open",
            limit.as_secs_f64()
        )
    };
    loop {
        let left = deadline.map(|d| d.saturating_duration_since(Instant::now()));
        match ZenohNode::open_within(config.clone(), "launcher", &instance, stop, left) {
            Ok(n) => return Ok(n),
            Err(_) if stop.load(Ordering::Relaxed) => return Ok(None),
            Err(NetError::OpenTimeout { .. }) => return Err(gave_up()),
            Err(e) if deadline.is_none_or(|d| Instant::now() < d) => {
                if Instant::now() >= notice_at {
                    notice_at = Instant::now() + Duration::from_secs(10);
                    tracing::warn!(error = %e, session = %described,
                        waited_s = started.elapsed().as_secs(),
                        "waiting for the Zenoh session to open; trying again until \
                         --peer-timeout-s {} s", limit.as_secs_f64());
                }
                std::thread::sleep(Duration::from_millis(500));
            }
            Err(e) => return Err(anyhow::Error::new(e).context(gave_up())),
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
        assert_eq!((role, file.as_path()), (Role::Echo, ok.as_path()));
        assert!(parse_child_config("echo")
            .unwrap_err()
            .contains("ROLE=FILE"));
        assert!(parse_child_config(&format!("router={}", ok.display()))
            .unwrap_err()
            .contains("planner, echo, processor, bridge"));
        let e = parse_child_config("echo=/nonexistent/x.json5").unwrap_err();
        assert!(e.contains("/nonexistent/x.json5"), "{e}");
    }

    /// A hub for the tests (nothing is created).
    fn test_hub() -> Hub {
        Hub {
            tcp_port: 17000,
            private_dir: PathBuf::from("/run/user/0/cellsar-mesh-x"),
        }
    }

    fn flags(connect: &[&str], listen: &[&str], mode: Option<Mode>) -> ZenohArgs {
        ZenohArgs {
            mode,
            connect: connect.iter().map(|s| s.to_string()).collect(),
            listen: listen.iter().map(|s| s.to_string()).collect(),
            ..ZenohArgs::default()
        }
    }

    /// Every accepted combination: the children connect to where the launcher listens (or to
    /// the same routers), and every flag set builds a configuration.
    #[test]
    fn children_join_the_launchers_network() {
        let hub = "tcp/127.0.0.1:17000";
        let private = "unixsock-stream//run/user/0/cellsar-mesh-x/hub.sock";
        // no flag: the private mesh on Unix sockets; the message limit is passed on
        let n = network(
            false,
            &ZenohArgs {
                max_message_bytes: Some(1 << 20),
                ..ZenohArgs::default()
            },
            &test_hub(),
        )
        .unwrap();
        assert_eq!(n.launcher.listen, [private]);
        assert_eq!(n.child.connect, [private]);
        assert!(n.child.listen.is_empty());
        assert_eq!(n.child.max_message_bytes, Some(1 << 20));
        // each child listens on a socket of its own, only there: no TCP listener
        assert_eq!(
            n.child_listen(Role::Echo, 3),
            [
                "--listen",
                "unixsock-stream//run/user/0/cellsar-mesh-x/echo-3.sock"
            ]
        );
        let mut echo = n.child.clone();
        echo.listen = vec![n.child_listen(Role::Echo, 3)[1].clone()];
        assert_eq!(
            echo.to_config()
                .unwrap()
                .get_json("listen/endpoints")
                .unwrap(),
            r#"["unixsock-stream//run/user/0/cellsar-mesh-x/echo-3.sock"]"#
        );
        // a peer or router launcher without -l: it listens on the hub, the children connect
        for mode in [None, Some(Mode::Peer), Some(Mode::Router)] {
            let user = ZenohArgs {
                no_multicast_scouting: true,
                ..flags(&["tcp/10.0.0.1:7447"], &[], mode)
            };
            let n = network(false, &user, &test_hub()).unwrap();
            assert_eq!(n.launcher.listen, [hub], "{mode:?}");
            assert_eq!(n.launcher.mode, mode);
            assert_eq!(n.child.mode, Some(Mode::Peer));
            assert_eq!(n.child.connect, ["tcp/10.0.0.1:7447", hub], "{mode:?}");
            assert_eq!(n.child.listen, [DEFAULT_LISTEN]);
            assert!(n.child.no_multicast_scouting);
            assert!(n.child_listen(Role::Echo, 0).is_empty());
        }
        // -l on every address: the children connect on loopback
        let n = network(false, &flags(&[], &["tcp/0.0.0.0:7447"], None), &test_hub()).unwrap();
        assert_eq!(n.launcher.listen, ["tcp/0.0.0.0:7447"]);
        assert_eq!(n.child.connect, ["tcp/127.0.0.1:7447"]);
        // a client launcher: the children get the same flags
        let user = flags(&["tcp/127.0.0.1:7447"], &[], Some(Mode::Client));
        let n = network(false, &user, &test_hub()).unwrap();
        assert_eq!((&n.launcher, &n.child), (&user, &user));
        // --router: everyone a client of the router child, on its Unix socket
        let n = network(true, &ZenohArgs::default(), &test_hub()).unwrap();
        assert_eq!(n.router.as_ref().unwrap().listen, [private]);
        assert_eq!(n.child.connect, [private]);
        assert_eq!(n.launcher.mode, Some(Mode::Client));
        assert!(n.child_listen(Role::Echo, 0).is_empty());
        for z in [&n.launcher, &n.child, n.router.as_ref().unwrap()] {
            z.to_config().unwrap();
        }
    }

    /// A `-c` file: the children get the same file, as peers, with its listen endpoints as
    /// connections (and its connect endpoints); one without listen endpoints gets the hub.
    #[test]
    fn a_configuration_file_is_passed_on_with_connections_to_the_launcher() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("z.json5");
        std::fs::write(
            &file,
            "{ mode: 'router', listen: { endpoints: ['tcp/[::]:17447'] }, \
             connect: { endpoints: ['tcp/10.0.0.2:7447'] } }",
        )
        .unwrap();
        let user = ZenohArgs {
            config: Some(file.clone()),
            ..ZenohArgs::default()
        };
        let n = network(false, &user, &test_hub()).unwrap();
        assert_eq!(n.launcher, user);
        assert_eq!(n.child.config.as_deref(), Some(file.as_path()));
        assert_eq!(n.child.mode, Some(Mode::Peer));
        assert_eq!(n.child.connect, ["tcp/10.0.0.2:7447", "tcp/[::1]:17447"]);
        assert_eq!(n.child.listen, [DEFAULT_LISTEN]);
        n.child.to_config().unwrap();
        let bare = dir.path().join("bare.json5");
        std::fs::write(&bare, "{ mode: 'peer' }").unwrap();
        let n = network(
            false,
            &ZenohArgs {
                config: Some(bare),
                ..ZenohArgs::default()
            },
            &test_hub(),
        )
        .unwrap();
        assert_eq!(n.launcher.listen, ["tcp/127.0.0.1:17000"]);
        assert_eq!(n.child.connect, ["tcp/127.0.0.1:17000"]);
    }

    /// What cannot form a mesh is refused, naming the flag or the file.
    #[test]
    fn combinations_that_cannot_form_a_mesh_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let port0 = dir.path().join("p0.json5");
        std::fs::write(&port0, "{ listen: { endpoints: ['tcp/127.0.0.1:0'] } }").unwrap();
        let from_file = ZenohArgs {
            config: Some(port0.clone()),
            ..ZenohArgs::default()
        };
        let cases: Vec<(bool, ZenohArgs, Vec<String>)> = vec![
            (
                false,
                flags(&[], &["tcp/127.0.0.1:0"], None),
                vec!["--listen tcp/127.0.0.1:0".into(), "port 0".into()],
            ),
            (
                false,
                from_file.clone(),
                vec![format!("-c {}", port0.display()), "port 0".into()],
            ),
            (true, from_file, vec!["--router with -c".into()]),
            (
                true,
                ZenohArgs {
                    multicast_scouting: true,
                    ..ZenohArgs::default()
                },
                vec!["--router with --multicast-scouting".into()],
            ),
            (
                true,
                flags(&["tcp/127.0.0.1:7447"], &[], None),
                vec!["--router with -e tcp/127.0.0.1:7447".into()],
            ),
            (
                true,
                flags(&[], &[], Some(Mode::Peer)),
                vec!["--router with -m peer".into()],
            ),
            (
                true,
                flags(&[], &["tcp/127.0.0.1:7448"], None),
                vec!["--router with -l tcp/127.0.0.1:7448".into()],
            ),
            (
                false,
                flags(
                    &["tcp/127.0.0.1:7447"],
                    &["tcp/127.0.0.1:7448"],
                    Some(Mode::Client),
                ),
                vec!["--listen tcp/127.0.0.1:7448".into(), "-m client".into()],
            ),
            (
                false,
                ZenohArgs {
                    no_multicast_scouting: true,
                    ..flags(&[], &[], Some(Mode::Client))
                },
                vec!["-m client".into(), "-e ROUTER".into()],
            ),
        ];
        for (router, user, named) in cases {
            let e = network(router, &user, &test_hub())
                .err()
                .unwrap_or_else(|| panic!("{user:?} accepted"));
            for n in named {
                assert!(e.contains(&n), "{n:?} in {e}");
            }
        }
        // a client without a router: refused, since multicast scouting is off by default ...
        let e = network(false, &flags(&[], &[], Some(Mode::Client)), &test_hub())
            .err()
            .unwrap();
        assert!(
            e.contains("-m client") && e.contains("--multicast-scouting"),
            "{e}"
        );
        // ... and accepted when it may find its router by multicast scouting, which the
        // children get too
        let user = ZenohArgs {
            multicast_scouting: true,
            ..flags(&[], &[], Some(Mode::Client))
        };
        let n = network(false, &user, &test_hub()).unwrap();
        assert!(n.launcher.multicast_scouting && n.child.multicast_scouting);
        assert_eq!(
            n.child
                .to_config()
                .unwrap()
                .get_json(zconfig::MULTICAST_SCOUTING_KEY)
                .unwrap(),
            "true"
        );
    }

    const TLS: &str = "transport: { link: { tls: { root_ca_certificate: '/c/ca.pem', \
        connect_private_key: '/c/x.key', connect_certificate: '/c/x.pem', \
        enable_mtls: true, close_link_on_expiration: true } } }";

    /// With TLS or access control the launcher is a client of the router, and every child it
    /// starts has its own configuration that enables them too; anything else is refused,
    /// naming the flag (or the role and `--child-config`).
    #[test]
    fn a_secure_run_has_clients_with_their_own_configurations() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str, text: String| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let client = |name: &str| {
            file(
                name,
                format!(
                    "{{ mode: 'client', connect: {{ endpoints: ['tls/10.0.0.1:7447'] }}, {TLS} }}"
                ),
            )
        };
        let launcher = client("launcher.json5");
        let peer = file(
            "peer.json5",
            format!("{{ mode: 'peer', listen: {{ endpoints: ['tls/127.0.0.1:7447'] }}, {TLS} }}"),
        );
        let plain = file(
            "plain.json5",
            "{ mode: 'client', connect: { endpoints: ['tcp/10.0.0.1:7447'] } }".into(),
        );
        let with = |f: &Path| ZenohArgs {
            config: Some(f.to_path_buf()),
            ..ZenohArgs::default()
        };
        // a peer or router launcher (by its file, or by -m): refused
        let e = network(false, &with(&peer), &test_hub()).err().unwrap();
        assert!(
            e.contains("peer.json5 (mode peer): with TLS settings"),
            "{e}"
        );
        assert!(e.contains("mode client"), "{e}");
        let e = network(
            false,
            &ZenohArgs {
                mode: Some(Mode::Router),
                ..with(&peer)
            },
            &test_hub(),
        )
        .err()
        .unwrap();
        assert!(e.starts_with("-m router: with TLS settings"), "{e}");
        // the same peer file without TLS forms the launcher's mesh
        let plain_peer = file(
            "plain-peer.json5",
            "{ mode: 'peer', listen: { endpoints: ['tcp/127.0.0.1:17447'] } }".into(),
        );
        network(false, &with(&plain_peer), &test_hub()).unwrap();
        // a client launcher: each child it starts has its own secure file
        let user = with(&launcher);
        let net = network(false, &user, &test_hub()).unwrap();
        let roles = [Role::Planner, Role::Echo, Role::Bridge];
        let own: Vec<(Role, PathBuf)> = roles
            .iter()
            .map(|r| (*r, client(&format!("{r}.json5"))))
            .collect();
        check_secure_children(&user, &net.child, &roles, &own).unwrap();
        // one missing: named, with the flag to give
        let e = check_secure_children(&user, &net.child, &roles, &own[..2]).unwrap_err();
        assert!(e.starts_with("--child-config bridge=FILE missing"), "{e}");
        assert!(e.contains("--external bridge"), "{e}");
        // one plain: named
        let mut mixed = own.clone();
        mixed[1].1 = plain.clone();
        let e = check_secure_children(&user, &net.child, &roles, &mixed).unwrap_err();
        assert!(
            e.starts_with(&format!(
                "--child-config echo={}: enables neither",
                plain.display()
            )),
            "{e}"
        );
        // the launcher's flags that the children get keep them secure: -e tcp/ refused
        let over = ZenohArgs {
            connect: vec!["tcp/10.0.0.1:7447".into()],
            ..user.clone()
        };
        let e = check_secure_children(&over, &over, &roles, &own).unwrap_err();
        assert!(
            e.contains("--connect tcp/10.0.0.1:7447: not a tls/ endpoint"),
            "{e}"
        );
        // a plain run: nothing asked of the children
        check_secure_children(&with(&plain), &with(&plain), &roles, &[]).unwrap();
        check_secure_children(&ZenohArgs::default(), &ZenohArgs::default(), &roles, &[]).unwrap();
    }
}
