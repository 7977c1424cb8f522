//! An iceoryx2 node of this process ([`FrameNode`]): created with the clean-up of dead
//! processes' resources, and opening the services of a [`FrameServiceSpec`].

use iceoryx2::prelude::*;

use super::error::ierr;
use super::{EventService, FrameService, FrameServiceSpec, IoxEnv, IoxError, IoxService};
use crate::frame::FrameHeader;

/// An iceoryx2 node of this process.
pub struct FrameNode {
    node: Node<IoxService>,
    name: String,
}

impl std::fmt::Debug for FrameNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameNode")
            .field("name", &self.name)
            .finish()
    }
}

/// What the start-up cleanup of dead processes' resources did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// Dead nodes whose resources were removed.
    pub cleaned: u64,
    /// Dead nodes that could not be cleaned (permissions or in use).
    pub failed: u64,
}

impl FrameNode {
    /// Creates a node named `name` in `env` and removes the resources of dead nodes (processes
    /// that crashed or were killed) so that their services, publishers and shared memory do
    /// not block this one.
    pub fn new(env: &IoxEnv, name: &str) -> Result<(Self, CleanupReport), IoxError> {
        let node_name = NodeName::new(name).map_err(|e| ierr("node name", name, e))?;
        // Clean up explicitly (below) rather than silently inside the builder, to report it.
        let mut config = env.config().clone();
        config.global.node.cleanup_dead_nodes_on_creation = false;
        let node = NodeBuilder::new()
            .name(&node_name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<IoxService>()
            .map_err(|e| ierr("create node", name, e))?;
        let state = node.try_cleanup_dead_nodes();
        let report = CleanupReport {
            cleaned: state.cleanups,
            failed: state.failed_cleanups,
        };
        if report.cleaned > 0 || report.failed > 0 {
            tracing::info!(
                node = name,
                cleaned = report.cleaned,
                failed = report.failed,
                "removed stale iceoryx2 resources of dead processes"
            );
        }
        Ok((
            FrameNode {
                node,
                name: name.to_string(),
            },
            report,
        ))
    }

    /// Node name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The underlying iceoryx2 node.
    pub fn node(&self) -> &Node<IoxService> {
        &self.node
    }

    pub(super) fn services(
        &self,
        spec: &FrameServiceSpec,
    ) -> Result<(FrameService, EventService), IoxError> {
        spec.validate()?;
        let name = ServiceName::new(&spec.name).map_err(|e| ierr("service name", &spec.name, e))?;
        let align = Alignment::new(8).ok_or_else(|| ierr("alignment", &spec.name, "8"))?;
        let ps = self
            .node
            .service_builder(&name)
            .publish_subscribe::<[u8]>()
            .user_header::<FrameHeader>()
            .payload_alignment(align)
            .max_publishers(spec.max_publishers)
            .max_subscribers(spec.max_subscribers)
            .max_nodes(spec.max_nodes)
            .history_size(spec.history)
            .subscriber_max_buffer_size(spec.subscriber_buffer)
            .subscriber_max_borrowed_samples(spec.subscriber_max_borrowed)
            .enable_safe_overflow(false)
            .open_or_create()
            .map_err(|e| ierr("open or create publish-subscribe service", &spec.name, e))?;
        let ev = self
            .node
            .service_builder(&name)
            .event()
            .max_notifiers(spec.max_publishers)
            .max_listeners(spec.max_subscribers)
            .max_nodes(spec.max_nodes)
            .open_or_create()
            .map_err(|e| ierr("open or create event service", &spec.name, e))?;
        Ok((ps, ev))
    }
}
