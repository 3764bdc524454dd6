//! Starting and supervising the server processes.

use couplet_protocol::Role;
use couplet_protocol::state::StateDirs;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// A server process started by the orchestrator.
pub struct Server {
    pub role: Role,
    child: Child,
}

#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    #[error("cannot start the {role}: {source}")]
    Spawn {
        role: &'static str,
        source: std::io::Error,
    },
    #[error("the {role} (pid {pid}) exited with {status}")]
    Died {
        role: &'static str,
        pid: u32,
        status: ExitStatus,
    },
    #[error("cannot query the {role}: {source}")]
    Query {
        role: &'static str,
        source: std::io::Error,
    },
}

impl Server {
    /// Starts `exe` (None: this executable) in `role` (`couplet fluid-server RUN_ID SCENE
    /// [--checkpoints DIR] [--restore DIR]`).
    pub fn spawn(
        role: Role,
        run_id: &str,
        scene: &Path,
        dirs: &StateDirs,
        exe: Option<&Path>,
    ) -> Result<Self, LaunchError> {
        let exe = match exe {
            Some(e) => e.to_owned(),
            None => std::env::current_exe().map_err(|source| LaunchError::Spawn {
                role: role.name(),
                source,
            })?,
        };
        let child = Command::new(exe)
            .arg(role.name())
            .arg(run_id)
            .arg(scene)
            .args(dirs.to_args())
            .stdin(Stdio::null())
            .spawn()
            .map_err(|source| LaunchError::Spawn {
                role: role.name(),
                source,
            })?;
        Ok(Self { role, child })
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Error if the process has exited (whatever its status: a server exits only when told).
    pub fn check(&mut self) -> Result<(), LaunchError> {
        match self.child.try_wait() {
            Ok(None) => Ok(()),
            Ok(Some(status)) => Err(LaunchError::Died {
                role: self.role.name(),
                pid: self.child.id(),
                status,
            }),
            Err(source) => Err(LaunchError::Query {
                role: self.role.name(),
                source,
            }),
        }
    }

    /// Waits up to `grace` for a clean exit, then kills. Returns the exit status if known.
    pub fn finish(&mut self, grace: Duration) -> Option<ExitStatus> {
        let start = Instant::now();
        while start.elapsed() < grace {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        self.child.wait().ok()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        // A server must never outlive its orchestrator, whatever path we leave by.
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
