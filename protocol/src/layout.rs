//! Which frame carries which pulses: a pure function of the mission's apertures, the samples
//! per pulse and the frame size, so the echo and the processor agree on every sequence number
//! without exchanging anything, and a re-sent frame keeps its number.

use radar_sim::track::Aperture;

/// Frames that cannot be laid out; the message names the flag or aperture.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct LayoutError(pub String);

/// Where one frame sits in the mission.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSlot {
    /// Aperture index.
    pub aperture: usize,
    /// Look within the aperture.
    pub look: usize,
    /// Chunk within the look.
    pub chunk: usize,
    /// First pulse within the aperture.
    pub first_pulse: usize,
    /// Pulses in the frame.
    pub pulses: usize,
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct ApLayout {
    first_seq: u64,
    looks: usize,
    pulses_per_look: usize,
}

/// The frames of a mission: each look of each aperture is cut into chunks of at most
/// `frame_pulses` pulses (frames never cross looks); sequence numbers count the frames of the
/// mission in order, from 0.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameLayout {
    frame_pulses: usize,
    chunks_per_look: usize,
    samples_per_pulse: usize,
    aps: Vec<ApLayout>,
}

impl FrameLayout {
    /// The layout for `apertures` with `samples_per_pulse` complex f32 samples per pulse and
    /// frames of at most `max_frame_bytes`.
    pub fn new(
        apertures: &[Aperture],
        samples_per_pulse: usize,
        max_frame_bytes: usize,
    ) -> Result<Self, LayoutError> {
        let pulse_bytes = samples_per_pulse.saturating_mul(8);
        if samples_per_pulse == 0 || max_frame_bytes < pulse_bytes {
            return Err(LayoutError(format!(
                "--max-frame-bytes {max_frame_bytes} is smaller than one pulse ({pulse_bytes} bytes)"
            )));
        }
        let ppl = apertures.first().map_or(1, |a| a.pulses_per_look).max(1);
        if let Some(a) = apertures.iter().find(|a| a.pulses_per_look != ppl) {
            return Err(LayoutError(format!(
                "aperture {} has {} pulses per look, aperture 0 has {ppl}: a mission's looks must be equal",
                a.index, a.pulses_per_look
            )));
        }
        let frame_pulses = (max_frame_bytes / pulse_bytes).min(ppl).max(1);
        let chunks_per_look = ppl.div_ceil(frame_pulses);
        let mut seq = 0u64;
        let mut aps = Vec::with_capacity(apertures.len());
        for a in apertures {
            aps.push(ApLayout {
                first_seq: seq,
                looks: a.looks,
                pulses_per_look: a.pulses_per_look,
            });
            seq += (a.looks * chunks_per_look) as u64;
        }
        Ok(FrameLayout {
            frame_pulses,
            chunks_per_look,
            samples_per_pulse,
            aps,
        })
    }

    /// Pulses per frame (the last chunk of a look may hold fewer).
    pub fn frame_pulses(&self) -> usize {
        self.frame_pulses
    }

    /// Complex samples per pulse.
    pub fn samples_per_pulse(&self) -> usize {
        self.samples_per_pulse
    }

    /// Apertures.
    pub fn apertures(&self) -> usize {
        self.aps.len()
    }

    /// Frames in the mission.
    pub fn total_frames(&self) -> u64 {
        self.aps
            .last()
            .map_or(0, |a| a.first_seq + (a.looks * self.chunks_per_look) as u64)
    }

    /// Frames of aperture `ap`.
    pub fn frames_of(&self, ap: usize) -> usize {
        self.aps
            .get(ap)
            .map_or(0, |a| a.looks * self.chunks_per_look)
    }

    /// The sequence numbers of aperture `ap` (or of one look of it).
    pub fn seqs(&self, ap: usize, look: Option<usize>) -> Vec<u64> {
        let Some(a) = self.aps.get(ap) else {
            return Vec::new();
        };
        let looks = match look {
            Some(l) if l < a.looks => l..l + 1,
            Some(_) => return Vec::new(),
            None => 0..a.looks,
        };
        looks
            .flat_map(|l| {
                (0..self.chunks_per_look)
                    .map(move |c| a.first_seq + (l * self.chunks_per_look + c) as u64)
            })
            .collect()
    }

    /// Where frame `seq` sits, or None if the mission has no such frame.
    pub fn locate(&self, seq: u64) -> Option<FrameSlot> {
        let k = self
            .aps
            .partition_point(|a| a.first_seq <= seq)
            .checked_sub(1)?;
        let a = &self.aps[k];
        let within = usize::try_from(seq - a.first_seq).ok()?;
        let (look, chunk) = (within / self.chunks_per_look, within % self.chunks_per_look);
        if look >= a.looks {
            return None;
        }
        let start = chunk * self.frame_pulses;
        let pulses = self.frame_pulses.min(a.pulses_per_look - start);
        Some(FrameSlot {
            aperture: k,
            look,
            chunk,
            first_pulse: look * a.pulses_per_look + start,
            pulses,
        })
    }

    /// The frame slots of aperture `ap` (or one look), in order.
    pub fn slots(&self, ap: usize, look: Option<usize>) -> Vec<(u64, FrameSlot)> {
        self.seqs(ap, look)
            .into_iter()
            .filter_map(|s| self.locate(s).map(|slot| (s, slot)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn aps(looks: &[usize], ppl: usize) -> Vec<Aperture> {
        let mut first = 0;
        looks
            .iter()
            .enumerate()
            .map(|(i, &l)| {
                let a = Aperture {
                    index: i,
                    landmark: Some(i),
                    centre_m: [0.0, 0.0],
                    t_start_s: i as f64 * 10.0,
                    t_end_s: i as f64 * 10.0 + l as f64,
                    look_s: 1.0,
                    looks: l,
                    pulses_per_look: ppl,
                    first_pulse: first,
                };
                first += l * ppl;
                a
            })
            .collect()
    }

    #[test]
    fn chunks_never_cross_looks() {
        let l = FrameLayout::new(&aps(&[2, 3], 100), 10, 8 * 10 * 30).unwrap();
        assert_eq!(l.frame_pulses(), 30);
        assert_eq!(l.frames_of(0), 8); // 4 chunks (30, 30, 30, 10) per look
        assert_eq!(l.total_frames(), 20);
        let s = l.locate(3).unwrap();
        assert_eq!(
            (s.aperture, s.look, s.chunk, s.first_pulse, s.pulses),
            (0, 0, 3, 90, 10)
        );
        let s = l.locate(8).unwrap();
        assert_eq!((s.aperture, s.look, s.first_pulse), (1, 0, 0));
        assert_eq!(l.seqs(1, Some(2)), vec![16, 17, 18, 19]);
        assert!(l.locate(20).is_none());
        assert!(l.seqs(1, Some(3)).is_empty());
    }

    #[test]
    fn too_small_frames_are_named() {
        let e = FrameLayout::new(&aps(&[1], 10), 4096, 1000).unwrap_err();
        assert!(e.to_string().contains("--max-frame-bytes 1000"), "{e}");
    }

    proptest! {
        /// Every pulse of every aperture is in exactly one frame, and locate inverts seqs.
        #[test]
        fn frames_tile_the_pulses(looks in proptest::collection::vec(1usize..5, 1..5),
                                  ppl in 2usize..50, fp in 1usize..60) {
            let a = aps(&looks, ppl);
            let l = FrameLayout::new(&a, 4, fp * 32).unwrap();
            let mut next_seq = 0u64;
            for (k, ap) in a.iter().enumerate() {
                let mut covered = vec![0u8; ap.pulses()];
                for (seq, slot) in l.slots(k, None) {
                    prop_assert_eq!(seq, next_seq);
                    next_seq += 1;
                    prop_assert_eq!(slot.aperture, k);
                    prop_assert!(slot.pulses >= 1 && slot.pulses <= fp);
                    // within one look
                    prop_assert_eq!(slot.first_pulse / ppl, (slot.first_pulse + slot.pulses - 1) / ppl);
                    for c in covered.iter_mut().skip(slot.first_pulse).take(slot.pulses) {
                        *c += 1;
                    }
                }
                prop_assert!(covered.iter().all(|c| *c == 1));
            }
            prop_assert_eq!(next_seq, l.total_frames());
        }
    }
}
