//! iceoryx2 service names, namespaced by run id so that several runs share a host.

/// The services of one run. Publish–subscribe services carry a [`crate::WindowHeader`]
/// (or are single-value control messages); `*Wake` are events used for
/// spin-then-block waiting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceLeaf {
    /// Orchestrator → servers: [`crate::Command`].
    Command,
    /// Servers → orchestrator: [`crate::Hello`].
    Hello,
    /// Servers → orchestrator: [`crate::SideReport`].
    Report,
    /// DEM → fluid, orchestrator: `[BodyState]`.
    Bodies,
    /// DEM → fluid: `[CouplingPoint]`.
    Points,
    /// Fluid → DEM, orchestrator: `[BodyLoad]`.
    Loads,
    /// Fluid → orchestrator: `[ParticleRecord]` at the output interval.
    Particles,
    /// Event that wakes the fluid server.
    FluidWake,
    /// Event that wakes the DEM server.
    DemWake,
    /// Event that wakes the orchestrator.
    OrchestratorWake,
}

impl ServiceLeaf {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Command => "command",
            Self::Hello => "hello",
            Self::Report => "report",
            Self::Bodies => "bodies",
            Self::Points => "points",
            Self::Loads => "loads",
            Self::Particles => "particles",
            Self::FluidWake => "wake/fluid",
            Self::DemWake => "wake/dem",
            Self::OrchestratorWake => "wake/orchestrator",
        }
    }
}

/// `couplet/<run-id>/<leaf>`.
pub fn service_name(run_id: &str, leaf: ServiceLeaf) -> String {
    format!("couplet/{run_id}/{}", leaf.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_namespaced_by_run() {
        assert_eq!(service_name("r1", ServiceLeaf::Points), "couplet/r1/points");
        assert_ne!(
            service_name("a", ServiceLeaf::Loads),
            service_name("b", ServiceLeaf::Loads)
        );
    }
}
