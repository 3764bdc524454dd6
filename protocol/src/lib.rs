//! The contract between couplet's processes: scene schema, zero-copy payloads,
//! iceoryx2 service names, protocol version and handshake, validation of received data,
//! checkpoint state files, the gRPC control API, the cell hash both servers search
//! neighbours with, the `[f64; 3]` arithmetic every crate uses, and the worker pool their
//! CPU sums run on.

pub use handshake::{HandshakeError, check_hello, check_hello_for};
pub use payload::{
    BodyLoad, BodyState, Command, CommandKind, CouplingPoint, Hello, PROTOCOL_VERSION,
    ParticleRecord, Role, SideReport, WindowHeader, monotonic_ns, scene_digest,
};
pub use scene::{
    BodySpec, ContactLaw, CouplingMode, CouplingScheme, DemSpec, DensityDiffusionForm, Domain,
    DragLawName, EffectsSpec, FluidBlock, FluidSpec, GravitySpec, InitialFlow, KernelKind, Meta,
    Motion, OutputSpec, PorosityPressure, Scene, SceneError, Shape, SoftSphereSpec, TimeSpec,
    ViscosityModel, WallKind, WallModel,
};
pub use service::{ServiceLeaf, service_name};
pub use validate::{ValidationError, validate_loads, validate_points, validate_states};
pub use worker_pool::in_worker_pool;

pub mod cell_hash;
pub mod handshake;
pub mod payload;
pub mod scene;
pub mod service;
pub mod standalone;
pub mod state;
pub mod transport;
pub mod validate;
pub mod vec3;
pub mod worker_pool;

/// The gRPC control API (`proto/couplet/v1/couplet.proto`): prost messages, the tonic
/// client and server, and the encoded descriptor set for server reflection.
pub mod grpc {
    tonic::include_proto!("couplet.v1");

    /// `FileDescriptorSet` of the API, for `tonic-reflection`.
    pub const FILE_DESCRIPTOR_SET: &[u8] =
        include_bytes!(concat!(env!("OUT_DIR"), "/couplet_descriptor.bin"));
}
