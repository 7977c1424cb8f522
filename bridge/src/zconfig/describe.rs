//! What a Zenoh configuration opens, in words ([`describe`]), and the configuration of a
//! client that waits for its router ([`waiting_client_json5`]).

use zenoh::Config;

use super::Mode;

/// The Zenoh configuration (JSON5) of a client that connects to `endpoint` and, like
/// `pipeline/deploy/client.json5`, waits for it as long as it takes: `connect.timeout_ms: -1`,
/// no exit on a failed connection, no multicast scouting (what the tests of a service started
/// before its router use).
pub fn waiting_client_json5(endpoint: &str) -> String {
    format!(
        "{{ mode: 'client', connect: {{ endpoints: ['{endpoint}'], timeout_ms: -1, \
         exit_on_failure: false }}, scouting: {{ multicast: {{ enabled: false }} }} }}"
    )
}

/// A one-line description of the session `config` opens, for messages and logs: its mode and
/// the endpoints it connects to and listens on as Zenoh will use them (those of a `--config`
/// file included; a mode-dependent list resolved for the mode), e.g. `mode client, connect
/// [tcp/192.168.1.10:7447], listen []`; `, multicast scouting on` is added when the session
/// also finds (and is found by) peers and routers by multicast (off is the default: nothing
/// added).
pub fn describe(config: &Config) -> String {
    let mode = effective_mode(config);
    let scouting = config.get_json(super::MULTICAST_SCOUTING_KEY).ok();
    format!(
        "mode {mode}, connect [{}], listen [{}]{}",
        effective_endpoints(config, "connect", &mode).join(", "),
        effective_endpoints(config, "listen", &mode).join(", "),
        if scouting.as_deref() == Some("true") {
            ", multicast scouting on"
        } else {
            ""
        }
    )
}

/// The session mode of `config` (`peer` when it sets none, as Zenoh does).
pub fn effective_mode(config: &Config) -> String {
    config
        .get_json("mode")
        .ok()
        .and_then(|s| serde_json::from_str::<Option<String>>(&s).ok().flatten())
        .unwrap_or_else(|| Mode::Peer.as_str().to_string())
}

/// The endpoints of `which` (`"connect"` or `"listen"`) in `config` for a session of `mode`:
/// the list itself, or the entry for `mode` of a mode-dependent value (`{router: [...], peer:
/// [...]}`); empty when there are none.
pub fn effective_endpoints(config: &Config, which: &str, mode: &str) -> Vec<String> {
    let Some(value) = config
        .get_json(&format!("{which}/endpoints"))
        .ok()
        .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
    else {
        return Vec::new();
    };
    let list = match &value {
        serde_json::Value::Object(per_mode) => per_mode.get(mode),
        other => Some(other),
    };
    list.and_then(serde_json::Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|e| e.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::zconfig::ZenohArgs;

    /// What a session is described by in messages: the mode and the effective endpoints,
    /// those of a configuration file included (mode-dependent lists resolved).
    #[test]
    fn the_waiting_client_configuration_is_a_client_of_its_endpoint() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.json5");
        std::fs::write(&p, waiting_client_json5("tcp/127.0.0.1:17448")).unwrap();
        let c = ZenohArgs {
            config: Some(p),
            ..Default::default()
        }
        .to_config()
        .unwrap();
        assert_eq!(
            describe(&c),
            "mode client, connect [tcp/127.0.0.1:17448], listen []"
        );
        let timeout = c.get_json("connect/timeout_ms").unwrap();
        assert!(timeout.contains("-1"), "{timeout}");
    }

    #[test]
    fn sessions_are_described_by_mode_and_endpoints() {
        let a = ZenohArgs {
            mode: Some(Mode::Client),
            connect: vec!["tcp/127.0.0.1:7447".into()],
            ..Default::default()
        };
        assert_eq!(
            describe(&a.to_config().unwrap()),
            "mode client, connect [tcp/127.0.0.1:7447], listen []"
        );
        assert_eq!(
            describe(&ZenohArgs::default().to_config().unwrap()),
            "mode peer, connect [], listen [tcp/127.0.0.1:0]"
        );
        let scouting = ZenohArgs {
            mode: Some(Mode::Client),
            multicast_scouting: true,
            ..Default::default()
        };
        assert_eq!(
            describe(&scouting.to_config().unwrap()),
            "mode client, connect [], listen [], multicast scouting on"
        );
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.json5");
        std::fs::write(
            &p,
            "{ mode: 'router', listen: { endpoints: { router: ['tcp/127.0.0.1:17447'], peer: ['tcp/127.0.0.1:0'] } } }",
        )
        .unwrap();
        let c = ZenohArgs {
            config: Some(p),
            ..Default::default()
        }
        .to_config()
        .unwrap();
        assert_eq!(
            effective_endpoints(&c, "listen", &effective_mode(&c)),
            ["tcp/127.0.0.1:17447"]
        );
        assert!(
            describe(&c).starts_with("mode router, "),
            "{}",
            describe(&c)
        );
        // the deployment's client configuration
        let client = ZenohArgs {
            config: Some(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../pipeline/deploy/client.json5"),
            ),
            ..Default::default()
        };
        assert_eq!(
            describe(&client.to_config().unwrap()),
            "mode client, connect [tcp/192.168.1.10:7447], listen []"
        );
    }
}
