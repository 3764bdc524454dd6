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
