//! The frame key of a mission on the processor's side ([`KeyGate`]): the echo draws a key per
//! mission, tags every frame with it and gives it to the processor in every answer to an
//! aperture request. A frame that fits the mission's layout is taken only when its tag
//! verifies under that key, so a peer that may put frames on the mission's key (the bridge)
//! cannot displace the echo's frames: its forgeries are counted (`forged`) and skipped, and
//! the slot they aimed at stays open for the echo's frame.
//!
//! Frames that arrive before the first answer (the frames travel by shared memory or their
//! own Zenoh key, the answer by the requester thread) are held, up to a bound, and filed when
//! the answer brings the key. An answer without a key (an echo that does not tag) lets frames
//! through unchecked.

use bridge::frame::{samples_as_bytes, FrameKey};
use bridge::{CodecError, MissionId};

use super::receive::RawFrame;

/// At most this many frames are held while a mission's key is not known yet.
pub(super) const PARKED_MAX_FRAMES: usize = 64;
/// At most this many sample bytes are held while a mission's key is not known yet.
pub(super) const PARKED_MAX_BYTES: usize = 16 << 20;

/// What becomes of a frame that fits the layout.
pub(super) enum Admit {
    /// Its tag verified (or the echo tags nothing): file it.
    Take(RawFrame),
    /// Held until the mission's key is known.
    Parked,
    /// Held frames fill the bound: dropped (asked for again like any lost frame).
    Overflow,
    /// Its tag is missing or does not verify: skip it, counted.
    Forged(CodecError),
}

/// A mission's frame key as learned from the echo, and the frames waiting for it.
#[derive(Default)]
pub(super) struct KeyGate {
    /// `None`: no answer yet; `Some(None)`: the echo tags nothing; `Some(Some(k))`: the key.
    key: Option<Option<FrameKey>>,
    parked: Vec<RawFrame>,
    parked_bytes: usize,
    /// A forged frame was logged at warn level (later ones at debug).
    warned: bool,
}

impl KeyGate {
    /// Decides on frame `f` (which fits the mission's layout).
    pub(super) fn admit(&mut self, f: RawFrame) -> Admit {
        match &self.key {
            Some(None) => Admit::Take(f),
            Some(Some(k)) => match f.header.verify_tag(k, samples_as_bytes(&f.samples)) {
                Ok(()) => Admit::Take(f),
                Err(e) => Admit::Forged(e),
            },
            None => {
                let bytes = std::mem::size_of_val(f.samples.as_slice());
                if self.parked.len() >= PARKED_MAX_FRAMES
                    || self.parked_bytes.saturating_add(bytes) > PARKED_MAX_BYTES
                {
                    return Admit::Overflow;
                }
                self.parked_bytes += bytes;
                self.parked.push(f);
                Admit::Parked
            }
        }
    }

    /// Logs forged frame `seq` of `mission`: the first at warn level, later ones at debug.
    pub(super) fn log_forged(&mut self, mission: MissionId, seq: u64, e: &CodecError) {
        if std::mem::replace(&mut self.warned, true) {
            tracing::debug!(%mission, seq, error = %e, "forged frame skipped");
        } else {
            tracing::warn!(%mission, seq, error = %e,
                "forged frame skipped (not tagged with the mission's key; later ones are logged at debug)");
        }
    }

    /// Notes the key of an answer from the echo (the latest answer's key replaces an earlier
    /// one: a restarted echo draws a new key) and returns the frames held for it.
    pub(super) fn on_ack(&mut self, key: Option<FrameKey>) -> Vec<RawFrame> {
        self.key = Some(key);
        self.parked_bytes = 0;
        std::mem::take(&mut self.parked)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bridge::frame::FrameMeta;
    use bridge::{Complex32, MissionId};

    fn frame(key: Option<&FrameKey>, seq: u64, value: f32) -> RawFrame {
        let samples = vec![Complex32::new(value, 1.0); 8];
        let mut meta = FrameMeta::iq(MissionId(3), seq, 500, 2, 4);
        if let Some(k) = key {
            meta = meta.tagged(k, samples_as_bytes(&samples));
        }
        let header = meta.header(None).unwrap();
        RawFrame {
            mission: MissionId(3),
            seq,
            mission_time_ns: 500,
            rows: 2,
            cols: 4,
            samples,
            header,
        }
    }

    #[test]
    fn frames_wait_for_the_key_then_only_tagged_ones_pass() {
        let k = FrameKey::from_bytes([1; 32]);
        let other = FrameKey::from_bytes([2; 32]);
        let mut g = KeyGate::default();
        assert!(matches!(g.admit(frame(Some(&k), 0, 1.0)), Admit::Parked));
        assert!(matches!(g.admit(frame(None, 1, 1.0)), Admit::Parked));
        let parked = g.on_ack(Some(k.clone()));
        assert_eq!(parked.len(), 2);
        let verdicts: Vec<bool> = parked
            .into_iter()
            .map(|f| matches!(g.admit(f), Admit::Take(_)))
            .collect();
        assert_eq!(verdicts, [true, false]);
        assert!(matches!(g.admit(frame(Some(&k), 2, 1.0)), Admit::Take(_)));
        assert!(matches!(
            g.admit(frame(Some(&other), 2, 1.0)),
            Admit::Forged(_)
        ));
        assert!(matches!(g.admit(frame(None, 2, 1.0)), Admit::Forged(_)));
        // a frame whose samples were changed after tagging
        let mut f = frame(Some(&k), 2, 1.0);
        f.samples[3].re = 7.0;
        assert!(matches!(g.admit(f), Admit::Forged(_)));
        // a restarted echo's new key replaces the old one
        g.on_ack(Some(other.clone()));
        assert!(matches!(
            g.admit(frame(Some(&other), 2, 1.0)),
            Admit::Take(_)
        ));
        assert!(matches!(g.admit(frame(Some(&k), 2, 1.0)), Admit::Forged(_)));
    }

    #[test]
    fn an_echo_without_keys_lets_frames_through_and_parking_is_bounded() {
        let mut g = KeyGate::default();
        for s in 0..PARKED_MAX_FRAMES as u64 {
            assert!(matches!(g.admit(frame(None, s, 0.0)), Admit::Parked));
        }
        assert!(matches!(g.admit(frame(None, 99, 0.0)), Admit::Overflow));
        assert_eq!(g.on_ack(None).len(), PARKED_MAX_FRAMES);
        assert!(matches!(g.admit(frame(None, 99, 0.0)), Admit::Take(_)));
        let k = FrameKey::from_bytes([5; 32]);
        assert!(matches!(g.admit(frame(Some(&k), 99, 0.0)), Admit::Take(_)));
    }

    /// Frames waiting for the key hold at most `PARKED_MAX_BYTES` of samples: 1 MiB frames
    /// overflow at the 17th, well before the count bound.
    #[test]
    fn parking_is_bounded_in_bytes_too() {
        let big = |seq: u64| {
            let mut f = frame(None, seq, 0.0);
            f.samples = vec![Complex32::new(0.0, 0.0); (1 << 20) / 8];
            f
        };
        let fit = PARKED_MAX_BYTES / (1 << 20);
        assert!(fit < PARKED_MAX_FRAMES);
        let mut g = KeyGate::default();
        for s in 0..fit as u64 {
            assert!(matches!(g.admit(big(s)), Admit::Parked), "frame {s}");
        }
        assert!(matches!(g.admit(big(fit as u64)), Admit::Overflow));
        // a small frame still fits under the count bound but not under the bytes
        assert!(matches!(g.admit(frame(None, 98, 0.0)), Admit::Overflow));
        assert_eq!(g.on_ack(None).len(), fit);
    }
}
