//! The processor's state directory: each finished aperture and the mission's metrics, stored
//! atomically before they are published, and restored after a restart.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use bridge::envelope::{self, DecodeLimits, Meta};

use super::context::{ApertureOutcome, StoredOutcome};
use crate::protocol::MissionMetrics;
use crate::services::os::write_atomic;
use crate::services::radar::{ServiceError, ServiceResult};

/// The file of aperture `k`'s outcome in `dir`.
fn outcome_path(dir: &Path, k: usize) -> PathBuf {
    dir.join(format!("aperture_{k:03}.outcome"))
}

/// Stores an aperture's outcome in `dir` (created if missing).
pub(super) fn store(dir: &Path, o: &ApertureOutcome) -> ServiceResult<()> {
    std::fs::create_dir_all(dir).map_err(|error| ServiceError::Io {
        path: dir.to_path_buf(),
        error,
    })?;
    let bytes = envelope::encode(&StoredOutcome { outcome: o.clone() }, Meta::default()).map_err(
        |error| ServiceError::Codec {
            what: format!("aperture {}", o.aperture()),
            error,
        },
    )?;
    write_atomic(&outcome_path(dir, o.aperture()), &bytes)?;
    Ok(())
}

/// Stores the mission's metrics in `dir` (created if missing).
pub(super) fn store_metrics(dir: &Path, m: &MissionMetrics) -> ServiceResult<()> {
    std::fs::create_dir_all(dir).map_err(|error| ServiceError::Io {
        path: dir.to_path_buf(),
        error,
    })?;
    let bytes = envelope::encode(m, Meta::default()).map_err(|error| ServiceError::Codec {
        what: "metrics".into(),
        error,
    })?;
    write_atomic(&dir.join("metrics.bin"), &bytes)?;
    Ok(())
}

/// The outcomes and (once every aperture is done) the metrics restored from a state directory.
pub(super) type Restored = (BTreeMap<usize, ApertureOutcome>, Option<MissionMetrics>);

/// Restores what `dir` holds for a mission of `apertures` apertures: files of other apertures,
/// unreadable or of an older schema are logged and skipped.
pub(super) fn restore(dir: &Path, apertures: usize) -> ServiceResult<Restored> {
    let limits = DecodeLimits {
        max_body_bytes: 64 << 20,
        verify_crc: true,
    };
    let mut out = BTreeMap::new();
    if !dir.exists() {
        return Ok((out, None));
    }
    for k in 0..apertures {
        let p = outcome_path(dir, k);
        if !p.exists() {
            continue;
        }
        let bytes = std::fs::read(&p).map_err(|error| ServiceError::Io {
            path: p.clone(),
            error,
        })?;
        match envelope::decode::<StoredOutcome>(&bytes, &limits) {
            Ok(e) if e.message.outcome.aperture() == k => {
                out.insert(k, e.message.outcome);
            }
            Ok(_) => {
                tracing::warn!(file = %p.display(), "stored outcome of another aperture, ignored")
            }
            Err(e) => {
                tracing::warn!(file = %p.display(), error = %e, "stored outcome unreadable, ignored")
            }
        }
    }
    let mp = dir.join("metrics.bin");
    let metrics = if out.len() == apertures && mp.exists() {
        let bytes = std::fs::read(&mp).map_err(|error| ServiceError::Io {
            path: mp.clone(),
            error,
        })?;
        envelope::decode::<MissionMetrics>(&bytes, &limits)
            .map(|e| e.message)
            .map_err(
                |e| tracing::warn!(file = %mp.display(), error = %e, "stored metrics unreadable"),
            )
            .ok()
    } else {
        None
    };
    Ok((out, metrics))
}
