//! The iceoryx2 environment: its flags ([`IoxArgs`]), the configuration processes share
//! ([`IoxEnv`]) and iceoryx2's log level.

use std::path::{Path, PathBuf};

use iceoryx2::prelude::*;

use super::error::ierr;
use super::IoxError;

/// Command-line flags selecting the iceoryx2 environment (flatten into a clap parser).
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct IoxArgs {
    /// Root directory of iceoryx2's files (default: iceoryx2's own, /tmp/iceoryx2).
    #[arg(id = "iox_root", long = "iox-root", value_name = "DIR")]
    pub root: Option<PathBuf>,
    /// Prefix of every iceoryx2 resource name (default: "iox2_"); processes only see each
    /// other with the same root and prefix.
    #[arg(id = "iox_prefix", long = "iox-prefix", value_name = "PREFIX")]
    pub prefix: Option<String>,
    /// An iceoryx2 configuration file (TOML); default: iceoryx2's built-in defaults.
    #[arg(id = "iox_config", long = "iox-config", value_name = "FILE")]
    pub config: Option<PathBuf>,
}

impl IoxArgs {
    /// The flags as command-line arguments (to pass them on to a child process).
    pub fn to_cli_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(c) = &self.config {
            v.push("--iox-config".into());
            v.push(c.display().to_string());
        }
        if let Some(r) = &self.root {
            v.push("--iox-root".into());
            v.push(r.display().to_string());
        }
        if let Some(p) = &self.prefix {
            v.push("--iox-prefix".into());
            v.push(p.clone());
        }
        v
    }

    /// The environment these flags select.
    pub fn env(&self) -> Result<IoxEnv, IoxError> {
        let mut config = match &self.config {
            Some(file) => {
                let s = file.display().to_string();
                let path = FilePath::new(s.as_bytes())
                    .map_err(|e| ierr("config path (--iox-config)", &s, e))?;
                Config::from_file(&path).map_err(|e| ierr("read config (--iox-config)", &s, e))?
            }
            None => Config::default(),
        };
        if let Some(p) = &self.prefix {
            config.global.prefix =
                FileName::new(p.as_bytes()).map_err(|e| ierr("set prefix (--iox-prefix)", p, e))?;
        }
        if let Some(r) = &self.root {
            std::fs::create_dir_all(r)
                .map_err(|e| ierr("create root (--iox-root)", &r.display().to_string(), e))?;
            let s = r.display().to_string();
            let path = iceoryx2::prelude::Path::new(s.as_bytes())
                .map_err(|e| ierr("set root (--iox-root)", &s, e))?;
            config.global.set_root_path(&path);
        }
        Ok(IoxEnv { config })
    }
}

/// The iceoryx2 configuration processes share (root directory + resource prefix).
#[derive(Clone, Debug)]
pub struct IoxEnv {
    config: Config,
}

impl IoxEnv {
    /// iceoryx2's built-in defaults (root `/tmp/iceoryx2`, prefix `iox2_`).
    pub fn default_env() -> Self {
        IoxEnv {
            config: Config::default(),
        }
    }

    /// An isolated environment: files under `root`, shared memory named `<prefix>...`.
    /// Use a unique prefix per test (e.g. `t<pid>_<n>_`).
    pub fn isolated(root: &Path, prefix: &str) -> Result<Self, IoxError> {
        IoxArgs {
            root: Some(root.to_path_buf()),
            prefix: Some(prefix.to_string()),
            config: None,
        }
        .env()
    }

    /// The iceoryx2 configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }
}

/// Sets iceoryx2's own log level (its messages go to `tracing`): `IOX2_LOG_LEVEL` if set,
/// else WARN.
pub fn init_iceoryx_logging() {
    set_log_level_from_env_or(LogLevel::Warn);
}
