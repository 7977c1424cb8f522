//! The roles the `cellsar` binary runs as a child that live in this crate: a plain Zenoh
//! router. (`cellsar bridge` is [`crate::services::bridge`], the same code and flags as
//! `cellsar-bridge`.)

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use bridge::zconfig::{self, Mode};
use bridge::{keys, ZenohArgs, ZenohNode};

use crate::exit::Failure;

/// Flags of `cellsar router`.
#[derive(clap::Args, Debug, Clone)]
pub struct RouterArgs {
    /// Instance name (liveliness token `cellsar/alive/router/<instance>`).
    #[arg(long, default_value = "router")]
    pub instance: String,
    /// Zenoh flags (mode defaults to router; give -l ENDPOINT or -c FILE).
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

/// A plain Zenoh router (what `zenohd` does without plugins) until `stop` is set. The flags
/// are checked before anything starts (bad input).
pub fn run_router(args: &RouterArgs, stop: &AtomicBool) -> Result<(), Failure> {
    let mut z = args.zenoh.clone();
    if z.listen.is_empty() && z.config.is_none() {
        return Err(Failure::bad_input(anyhow!("a router needs an endpoint to listen on: give -l ENDPOINT (e.g. -l tcp/0.0.0.0:7447) or -c FILE")));
    }
    if z.mode.is_none() {
        z.mode = Some(Mode::Router);
    }
    let config = z
        .to_config()
        .context("router configuration")
        .map_err(Failure::bad_input)?;
    keys::alive("router", &args.instance).map_err(Failure::bad_input)?;
    route(args, &z, config, stop).map_err(Failure::runtime)
}

fn route(
    args: &RouterArgs,
    z: &ZenohArgs,
    config: bridge::zenoh::Config,
    stop: &AtomicBool,
) -> Result<()> {
    // the endpoints as Zenoh uses them: from the flags or from the -c file
    let mode = zconfig::effective_mode(&config);
    let listen = zconfig::effective_endpoints(&config, "listen", &mode);
    let connect = zconfig::effective_endpoints(&config, "connect", &mode);
    let from = match (&z.config, z.listen.is_empty()) {
        (Some(file), true) => format!("{}", file.display()),
        _ => "flags".to_string(),
    };
    let Some(node) = ZenohNode::open_until(config, "router", &args.instance, stop)? else {
        return Ok(());
    };
    tracing::info!(instance = %args.instance, %mode, listen = ?listen, connect = ?connect,
        endpoints_from = %from, "router running");
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
    }
    node.close()?;
    Ok(())
}
