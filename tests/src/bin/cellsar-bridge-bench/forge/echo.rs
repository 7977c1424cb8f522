//! `forge --ask-echo`, `--answer-echo`, `--read-frames`: what a peer holding the bridge's
//! certificate must not do with the echo, for the frames' tags rest on it (the echo's frame key
//! travels only in its answers to aperture requests on `cellsar/<m>/echo/request`, which go to
//! whoever asked). Every round and for every mission it forges for:
//!
//! - `--ask-echo`: it asks the echo for aperture 0, look 0 (which every mission has), with the
//!   mission's pulses per frame when `--iq-plan-dir` gives the layout (else 1), as a processor
//!   does: the echo's answer carries the mission's frame key;
//! - `--answer-echo`: it declares a queryable on the mission's echo request key (once) and
//!   answers every aperture request it gets as the echo would, giving a frame key of its own
//!   (the one its layout-fitting frames are tagged under, `iq.rs`): a processor that took it
//!   would take those frames;
//! - `--read-frames`: it subscribes to the mission's echo key (the IQ frames; once).
//!
//! Only what other sessions send counts: its queryable takes no query of its own and its
//! subscriber no frame it puts itself (`Locality::Remote`), so with `--forge-iq` and
//! `--flood-queries` it still counts only what the router let reach it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use bridge::net::{QueryOptions, WireFormat};
use bridge::zenoh::handlers::FifoChannelHandler;
use bridge::zenoh::pubsub::Subscriber;
use bridge::zenoh::query::{Query, Queryable};
use bridge::zenoh::sample::{Locality, Sample};
use bridge::zenoh::Wait;
use bridge::{MissionId, NetError, ZenohNode};
use pipeline::protocol::{keys, ApertureRequest, RequestAck};
use serde::Serialize;

use super::iq::{self, IqArgs};

/// How long an aperture request of the forger waits for the echo's answer.
const ASK_TIMEOUT: Duration = Duration::from_millis(500);

/// The flags of what it tries with the echo.
#[derive(clap::Args, Debug, Clone)]
pub(in super::super) struct EchoArgs {
    /// Every round and for every mission: ask the echo for aperture 0, look 0, as a processor
    /// does (the answer carries the mission's frame key).
    #[arg(long)]
    ask_echo: bool,
    /// Declare a queryable on every mission's echo request key and answer every aperture
    /// request with a frame key of the forger's own.
    #[arg(long)]
    answer_echo: bool,
    /// Subscribe to every mission's echo key (the IQ frames).
    #[arg(long)]
    read_frames: bool,
}

/// What it tried with the echo and what came of it.
#[derive(Debug, Default, Serialize)]
pub(super) struct EchoTried {
    /// Aperture requests sent to the echo.
    pub asked: u64,
    /// Of them, answered with an acknowledgement.
    pub answered: u64,
    /// Of those, acknowledgements that carried the mission's frame key.
    pub keys: u64,
    /// Of them, refused by a queryable (a typed refusal, as the echo refuses).
    pub refused: u64,
    /// Of them, answered with an untyped error text: no cellsar queryable sends one (they
    /// refuse with typed refusals), so it is Zenoh's own (printed to stderr).
    pub untyped_errors: u64,
    /// Queryables declared on echo request keys.
    pub queryables: u64,
    /// Aperture requests its queryables got (from other sessions).
    pub requests: u64,
    /// Answers it sent to them (with its own frame key).
    pub answers: u64,
    /// Subscribers declared on echo keys.
    pub subscribers: u64,
    /// Samples its subscribers to the echo keys received (from other sessions).
    pub frames: u64,
    /// Declarations, requests or replies that failed here.
    pub errors: u64,
}

/// What it holds for one mission.
struct Watch {
    id: MissionId,
    queryable: Option<Queryable<FifoChannelHandler<Query>>>,
    _subscriber: Option<Subscriber<()>>,
}

/// Its queryables and subscribers, by mission, and the frames they received.
#[derive(Default)]
pub(super) struct Echo {
    watches: Vec<Watch>,
    frames: Arc<AtomicU64>,
}

impl Echo {
    /// One round for mission `id` (nothing without the flags): declares what `a` asks for on
    /// its first round, answers the requests its queryable got, and asks the echo.
    pub(super) fn round(
        &mut self,
        node: &ZenohNode,
        id: MissionId,
        instance: &str,
        (a, iq): (&EchoArgs, &IqArgs),
        r: &mut EchoTried,
    ) {
        if !(a.ask_echo || a.answer_echo || a.read_frames) {
            return;
        }
        if !self.watches.iter().any(|w| w.id == id) {
            let w = self.watch(node, id, a, r);
            self.watches.push(w);
        }
        r.frames = self.frames.load(Ordering::Relaxed);
        if let Some(q) = self
            .watches
            .iter()
            .find(|w| w.id == id)
            .and_then(|w| w.queryable.as_ref())
        {
            while let Ok(Some(query)) = q.try_recv() {
                r.requests += 1;
                match answer(&query, id, iq) {
                    Ok(()) => {
                        r.answers += 1;
                        eprintln!(
                            "answered an aperture request of mission {id} with a key of its own"
                        );
                    }
                    Err(e) => {
                        r.errors += 1;
                        eprintln!("answering an aperture request of mission {id}: {e}");
                    }
                }
            }
        }
        if a.ask_echo {
            ask(node, id, instance, iq, r);
        }
    }

    /// The queryable and the subscriber of mission `id` that `a` asks for.
    fn watch(&self, node: &ZenohNode, id: MissionId, a: &EchoArgs, r: &mut EchoTried) -> Watch {
        let mut w = Watch {
            id,
            queryable: None,
            _subscriber: None,
        };
        if a.answer_echo {
            let declared = keys::echo_request(id)
                .map_err(|e| e.to_string())
                .and_then(|k| {
                    node.session()
                        .declare_queryable(k)
                        .allowed_origin(Locality::Remote)
                        .wait()
                        .map_err(|e| e.to_string())
                });
            match declared {
                Ok(q) => {
                    r.queryables += 1;
                    w.queryable = Some(q);
                }
                Err(e) => {
                    r.errors += 1;
                    eprintln!("declaring a queryable on mission {id}'s echo requests: {e}");
                }
            }
        }
        if a.read_frames {
            let frames = self.frames.clone();
            let declared = keys::echo(id).map_err(|e| e.to_string()).and_then(|k| {
                node.session()
                    .declare_subscriber(k)
                    .allowed_origin(Locality::Remote)
                    .callback(move |_: Sample| {
                        frames.fetch_add(1, Ordering::Relaxed);
                    })
                    .wait()
                    .map_err(|e| e.to_string())
            });
            match declared {
                Ok(s) => {
                    r.subscribers += 1;
                    w._subscriber = Some(s);
                }
                Err(e) => {
                    r.errors += 1;
                    eprintln!("subscribing to mission {id}'s echo key: {e}");
                }
            }
        }
        w
    }
}

/// The pulses per frame of the mission's layout (`--iq-plan-dir`), else 1.
fn frame_pulses(iq: &IqArgs) -> u32 {
    match iq::fit(iq) {
        Some(Ok(fit)) => fit.layout.frame_pulses() as u32,
        _ => 1,
    }
}

/// The scene digest the echo expects, when the mission's scene is known (else none).
fn scene_digest(iq: &IqArgs) -> u64 {
    match iq::fit(iq) {
        Some(Ok(fit)) => fit.scene_digest,
        _ => 0,
    }
}

/// Asks the echo for aperture 0, look 0 of mission `id`, as a processor does; counts the
/// answer.
fn ask(node: &ZenohNode, id: MissionId, instance: &str, iq: &IqArgs, r: &mut EchoTried) {
    let Ok(key) = keys::echo_request(id) else {
        r.errors += 1;
        return;
    };
    let request = ApertureRequest {
        mission_id: id,
        aperture: 0,
        look: Some(0),
        frame_pulses: frame_pulses(iq),
        scene_digest: scene_digest(iq),
        requester: instance.to_string(),
    };
    let opts = QueryOptions {
        timeout: ASK_TIMEOUT,
        ..QueryOptions::default()
    };
    r.asked += 1;
    match node.query_one::<_, RequestAck>(&key, &request, &opts) {
        Ok(ack) => {
            r.answered += 1;
            if ack.message.frame_key.is_some() {
                r.keys += 1;
                eprintln!("the echo gave it mission {id}'s frame key");
            }
        }
        Err(NetError::NoReply { .. }) => {}
        Err(NetError::Refused { .. }) => r.refused += 1,
        Err(NetError::Remote { message, .. }) => {
            r.untyped_errors += 1;
            eprintln!("asking the echo of mission {id}: an untyped error reply: {message}");
        }
        Err(e) => {
            r.errors += 1;
            eprintln!("asking the echo of mission {id}: {e}");
        }
    }
}

/// Answers `query` (an aperture request of mission `id`) as the echo would, with the forger's
/// own frame key and the frame numbers of the layout (`--iq-plan-dir`; none without it).
fn answer(query: &Query, id: MissionId, iq: &IqArgs) -> Result<(), String> {
    let format = query.encoding().map(WireFormat::of).unwrap_or_default();
    let payload = query.payload().ok_or("an empty request")?;
    let request = format
        .decode_zbytes::<ApertureRequest>(payload, &bridge::DecodeLimits::default())
        .map_err(|e| e.to_string())?
        .message;
    let seqs = match iq::fit(iq) {
        Some(Ok(fit)) => fit
            .layout
            .seqs(request.aperture as usize, request.look.map(|l| l as usize)),
        _ => Vec::new(),
    };
    let ack = RequestAck {
        mission_id: request.mission_id,
        aperture: request.aperture,
        look: request.look,
        seqs,
        queued_before: 0,
        queued: true,
        frame_key: iq::own_key().cloned(),
    };
    let meta = bridge::Meta {
        mission_id: id,
        ..bridge::Meta::default()
    };
    let bytes = format.encode(&ack, meta).map_err(|e| e.to_string())?;
    query
        .reply(query.key_expr().clone(), bytes)
        .encoding(format.encoding::<RequestAck>())
        .wait()
        .map_err(|e| e.to_string())
}
