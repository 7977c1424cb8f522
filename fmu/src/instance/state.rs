//! FMU states: snapshots of an instance, the boxes handed to the importer, and their
//! serialization.

use super::*;

const STATE_MAGIC: u64 = 0x43454c4c_53544154; // "CELLSTAT"
const STATE_HEADER: &[u8; 8] = b"CSFMUST1";

/// A saved FMU state (what `GetFMUState` hands out).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    kind: ModelKind,
    version: FmiVersion,
    mode: Mode,
    core: Core,
    start_time: f64,
    stop_time: Option<f64>,
    time: f64,
    terminated: bool,
}

/// The object behind an `fmi2FMUstate` / `fmi3FMUState` pointer.
#[repr(C)]
#[derive(Debug)]
pub struct StateBox {
    magic: u64,
    snapshot: Snapshot,
}

impl StateBox {
    /// The saved state.
    pub fn snapshot_ref(&self) -> &Snapshot {
        &self.snapshot
    }

    /// Overwrites the saved state.
    pub fn replace(&mut self, snapshot: Snapshot) {
        self.snapshot = snapshot;
    }

    /// A boxed state, as a raw pointer for the importer.
    pub fn into_raw(snapshot: Snapshot) -> *mut c_void {
        Box::into_raw(Box::new(StateBox {
            magic: STATE_MAGIC,
            snapshot,
        }))
        .cast()
    }

    /// The state behind a pointer from [`StateBox::into_raw`].
    ///
    /// # Safety
    /// `ptr` must be null or a pointer this library handed out and not yet freed.
    pub unsafe fn from_ptr<'a>(ptr: *mut c_void) -> Result<&'a mut StateBox, FmuError> {
        let p = ptr.cast::<StateBox>();
        // SAFETY: the caller guarantees `ptr` is null or a live StateBox.
        match unsafe { p.as_mut() } {
            Some(s) if s.magic == STATE_MAGIC => Ok(s),
            Some(_) => Err(FmuError::error(
                "the FMU state pointer does not point to a state of this FMU",
            )),
            None => Err(FmuError::error("the FMU state pointer is NULL")),
        }
    }

    /// Frees a state from [`StateBox::into_raw`].
    ///
    /// # Safety
    /// As for [`StateBox::from_ptr`]; the pointer must not be used afterwards.
    pub unsafe fn free(ptr: *mut c_void) -> Result<(), FmuError> {
        // SAFETY: forwarded.
        let s = unsafe { Self::from_ptr(ptr) }?;
        s.magic = 0;
        // SAFETY: the pointer came from Box::into_raw and is freed once (magic cleared above).
        drop(unsafe { Box::from_raw(ptr.cast::<StateBox>()) });
        Ok(())
    }
}

impl Instance {
    /// A copy of the current state.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            kind: self.core.info().kind,
            version: self.version,
            mode: self.mode,
            core: self.core.clone(),
            start_time: self.start_time,
            stop_time: self.stop_time,
            time: self.time,
            terminated: self.terminated,
        }
    }

    /// Restores a state taken from an instance of the same model and FMI version.
    pub fn restore(&mut self, s: &Snapshot) -> Result<(), FmuError> {
        if s.kind != self.core.info().kind || s.version != self.version {
            return Err(FmuError::error(
                "the FMU state belongs to a different model or FMI version",
            ));
        }
        self.mode = s.mode;
        self.core = s.core.clone();
        self.start_time = s.start_time;
        self.stop_time = s.stop_time;
        self.time = s.time;
        self.terminated = s.terminated;
        Ok(())
    }

    /// Serialises a state: header, this model's GUID, bincode body.
    pub fn serialize_state(&self, s: &Snapshot) -> Result<Vec<u8>, FmuError> {
        let mut out = STATE_HEADER.to_vec();
        let g = self.guid();
        out.extend_from_slice(&(g.len() as u32).to_le_bytes());
        out.extend_from_slice(g.as_bytes());
        let body = bincode::serde::encode_to_vec(s, bincode::config::standard())
            .map_err(|e| FmuError::error(format!("cannot serialise the FMU state: {e}")))?;
        out.extend_from_slice(&body);
        Ok(out)
    }

    /// Reads a state written by [`Instance::serialize_state`] of the same model.
    pub fn deserialize_state(&self, bytes: &[u8]) -> Result<Snapshot, FmuError> {
        let bad = |why: &str| FmuError::error(format!("serialized FMU state rejected: {why}"));
        let rest = bytes
            .strip_prefix(STATE_HEADER.as_slice())
            .ok_or_else(|| bad("wrong header"))?;
        let len_bytes: [u8; 4] = rest
            .get(..4)
            .and_then(|b| b.try_into().ok())
            .ok_or_else(|| bad("truncated"))?;
        let len = u32::from_le_bytes(len_bytes) as usize;
        let g = rest.get(4..4 + len).ok_or_else(|| bad("truncated"))?;
        if g != self.guid().as_bytes() {
            return Err(bad("it was written by a different model or version"));
        }
        let body = &rest[4 + len..];
        let (s, used): (Snapshot, usize) = bincode::serde::decode_from_slice(
            body,
            bincode::config::standard().with_limit::<{ 64 << 20 }>(),
        )
        .map_err(|e| bad(&e.to_string()))?;
        if used != body.len() {
            return Err(bad("trailing bytes"));
        }
        Ok(s)
    }
}
