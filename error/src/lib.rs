//! # cellsar-error
//!
//! How every cellsar binary prints an error ([`error_chain`]), maps it to an exit code
//! ([`exit`]) and sets up its log ([`init_logging`]). A crate of its own because the
//! transport crate (`bridge`) needs it and cannot depend on the planner (the planner depends on
//! it), while the planner also builds without the transport (for the FMU).

pub mod exit;

/// The message of `error` followed by each cause in its `source()` chain that the message
/// does not already contain, joined by ": ".
///
/// Many error types here include their source in their own message (so that `to_string()`
/// alone, as sent in a service's error reply, is complete) and also expose it as `source()`;
/// printing the chain with `{:#}` would then name the same cause twice. Binaries print errors
/// through this function so that each cause appears once.
pub fn error_chain(error: &(dyn std::error::Error + 'static)) -> String {
    let mut msg = error.to_string();
    let mut cause = error.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        cause = c.source();
    }
    msg
}

/// The default log filter of a one-shot command (a plan, a simulation, a run): warnings and
/// errors only, so that its own output stays readable.
pub const COMMAND_LOG_FILTER: &str = "warn";

/// The default log filter of a long-running service (`serve`, `echo`, `process-service`, the
/// bridge, the router): also info, so that it shows that it runs, what it serves and its
/// counters.
pub const SERVICE_LOG_FILTER: &str = "info";

/// Sets up `tracing` for a binary: the filter from `RUST_LOG`, else `default_filter` (e.g.
/// `"warn"`); output to stderr, with ANSI colours only when stderr is a terminal (no escape
/// codes in redirected logs). Call once, first thing in `main`.
pub fn init_logging(default_filter: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}

#[cfg(test)]
mod tests {
    use super::error_chain;

    #[derive(Debug, thiserror::Error)]
    #[error("reading {path}: {source}")]
    struct Outer {
        path: String,
        #[source]
        source: std::io::Error,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("cannot plan")]
    struct Terse {
        #[source]
        source: Outer,
    }

    #[test]
    fn each_cause_is_named_once() {
        let inner = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let outer = Outer {
            path: "m.toml".into(),
            source: inner,
        };
        assert_eq!(error_chain(&outer), "reading m.toml: no such file");
        let terse = Terse { source: outer };
        assert_eq!(
            error_chain(&terse),
            "cannot plan: reading m.toml: no such file"
        );
        let any = anyhow::Error::new(terse).context("plan service");
        assert_eq!(
            error_chain(any.as_ref()),
            "plan service: cannot plan: reading m.toml: no such file"
        );
    }
}
