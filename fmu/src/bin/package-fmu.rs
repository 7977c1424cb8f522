//! `package-fmu`: writes `<target>/fmu/fmi2/CellsarPlanner.fmu`, `<target>/fmu/fmi3/CellsarPlanner.fmu`
//! (and the partner `LandmarkMover.fmu` beside each) from the shared library built with it.
//!
//! ```text
//! cargo run --release -p fmu --bin package-fmu [-- --lib PATH --out DIR]
//! ```

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::Parser;
use fmu::core::{FmiVersion, MODELS};

/// Packages the cellsar FMUs.
#[derive(Debug, Parser)]
#[command(version, about)]
struct Args {
    /// The shared library to package (default: build it with this executable's cargo profile
    /// and take `libfmu.so` beside this executable).
    #[arg(long)]
    lib: Option<PathBuf>,
    /// Output directory (default: `<cargo target dir>/fmu`).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The workspace's target directory: `CARGO_TARGET_DIR`, else what `cargo metadata` says.
fn target_dir() -> Result<PathBuf> {
    if let Some(dir) = std::env::var_os("CARGO_TARGET_DIR") {
        let dir = PathBuf::from(dir);
        return Ok(if dir.is_absolute() {
            dir
        } else {
            std::env::current_dir()?.join(dir)
        });
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let out = Command::new(&cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--manifest-path",
        ])
        .arg(&manifest)
        .output()
        .with_context(|| format!("running `{} metadata`", cargo.to_string_lossy()))?;
    if !out.status.success() {
        bail!(
            "`cargo metadata` failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let meta: serde_json::Value =
        serde_json::from_slice(&out.stdout).context("parsing `cargo metadata` output")?;
    let dir = meta["target_directory"]
        .as_str()
        .context("`cargo metadata` gave no target_directory")?;
    Ok(PathBuf::from(dir))
}

/// Builds the cdylib with the profile this executable was built with (`cargo run --bin` does
/// not build it) and returns its path, beside this executable.
fn build_library() -> Result<PathBuf> {
    let exe = std::env::current_exe()?;
    let dir = exe.parent().context("executable has no directory")?;
    let profile = dir
        .file_name()
        .and_then(|n| n.to_str())
        .context("cannot tell the cargo profile from the executable's directory")?;
    let profile = if profile == "debug" { "dev" } else { profile };
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    tracing::info!("building the shared library (cargo build -p fmu --lib --profile {profile})");
    let status = Command::new(&cargo)
        .args([
            "build",
            "-p",
            "fmu",
            "--lib",
            "--profile",
            profile,
            "--manifest-path",
        ])
        .arg(&manifest)
        .status()
        .with_context(|| format!("running `{} build`", cargo.to_string_lossy()))?;
    if !status.success() {
        bail!("building the shared library failed ({status})");
    }
    Ok(dir.join("libfmu.so"))
}

fn main() -> Result<()> {
    cellsar_error::init_logging("info");
    let args = Args::parse();
    let lib = match args.lib {
        Some(l) => l,
        None => build_library()?,
    };
    let library = std::fs::read(&lib).with_context(|| {
        format!(
            "reading the shared library {} (build it with `cargo build --release -p fmu`, or pass --lib)",
            lib.display()
        )
    })?;
    let out = match args.out {
        Some(o) => o,
        None => target_dir()?.join("fmu"),
    };
    for version in [FmiVersion::Fmi2, FmiVersion::Fmi3] {
        let dir = out.join(match version {
            FmiVersion::Fmi2 => "fmi2",
            FmiVersion::Fmi3 => "fmi3",
        });
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for info in MODELS {
            let bytes = fmu::package::fmu_archive(info, version, &library)
                .with_context(|| format!("packaging {}", info.identifier))?;
            let path = dir.join(format!("{}.fmu", info.identifier));
            std::fs::write(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
            tracing::info!(
                "wrote {} (FMI {}, {} bytes)",
                path.display(),
                version.as_str(),
                bytes.len()
            );
            println!("{}", path.display());
        }
    }
    Ok(())
}
