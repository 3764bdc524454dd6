//! The contract between couplet's processes: scene schema, zero-copy payloads,
//! iceoryx2 service names, protocol version and handshake, validation of received data.

pub use payload::{
    BodyLoad, BodyState, Command, CommandKind, CouplingPoint, Hello, ParticleRecord, Role,
    SideReport, WindowHeader, monotonic_ns, PROTOCOL_VERSION,
};
pub use handshake::{check_hello, HandshakeError};
pub use scene::{
    BodySpec, CouplingMode, CouplingScheme, DemSpec, Domain, EffectsSpec, FluidBlock, FluidSpec,
    GravitySpec, KernelKind, Meta, Motion, Scene, SceneError, Shape, TimeSpec, ViscosityModel,
    WallKind,
};
pub use service::{service_name, ServiceLeaf};
pub use validate::{validate_loads, validate_points, validate_states, ValidationError};

pub mod handshake;
pub mod payload;
pub mod scene;
pub mod service;
pub mod transport;
pub mod validate;
