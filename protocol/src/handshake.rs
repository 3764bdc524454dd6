//! The handshake: each server's first message is a [`Hello`]; the orchestrator refuses a
//! peer that speaks another protocol version or claims an unknown role.

use crate::payload::{Hello, PROTOCOL_VERSION, Role};

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HandshakeError {
    #[error(
        "{role} (pid {pid}) speaks protocol version {got}, this build speaks {PROTOCOL_VERSION}: refusing it"
    )]
    Version {
        role: &'static str,
        pid: u32,
        got: u32,
    },
    #[error("hello from pid {pid} claims unknown role {role}")]
    UnknownRole { pid: u32, role: u32 },
    #[error("hello from pid {pid}: dt_limit = {dt} s must be positive and finite")]
    Limit { pid: u32, dt: f64 },
    #[error(
        "the {role} (pid {pid}) loaded another scene than this run's (digest {got:08x}, the run's {want:08x}): start it on the scene file the orchestrator wrote, OUT/scene.toml"
    )]
    Scene {
        role: &'static str,
        pid: u32,
        got: u32,
        want: u32,
    },
}

/// Accepts a hello for a run of the scene whose [`crate::payload::scene_digest`] is
/// `scene`: [`check_hello`], and the server must have loaded that same scene.
pub fn check_hello_for(h: &Hello, scene: u32) -> Result<Role, HandshakeError> {
    let role = check_hello(h)?;
    if h.scene_digest != scene {
        return Err(HandshakeError::Scene {
            role: role.name(),
            pid: h.pid,
            got: h.scene_digest,
            want: scene,
        });
    }
    Ok(role)
}

/// Accepts a hello: returns the peer's role, or why it is refused.
pub fn check_hello(h: &Hello) -> Result<Role, HandshakeError> {
    let role = match Role::from_u32(h.role) {
        Some(r @ (Role::Fluid | Role::Dem)) => r,
        _ => {
            return Err(HandshakeError::UnknownRole {
                pid: h.pid,
                role: h.role,
            });
        }
    };
    if h.protocol_version != PROTOCOL_VERSION {
        return Err(HandshakeError::Version {
            role: role.name(),
            pid: h.pid,
            got: h.protocol_version,
        });
    }
    if !(h.dt_limit.is_finite() && h.dt_limit > 0.0) {
        return Err(HandshakeError::Limit {
            pid: h.pid,
            dt: h.dt_limit,
        });
    }
    Ok(role)
}
