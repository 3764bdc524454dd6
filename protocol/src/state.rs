//! Checkpoint files: every process writes its whole state at a window boundary into
//! `DIR/step-<n>/<role>.state` (DIR the run's checkpoint folder, n the index of the next
//! window), and a restored run reads it back before its first window. A file is a
//! bincode-encoded [`StateHeader`] (magic, protocol version, role, boundary) followed by
//! the role's own state, also bincode; it is written to a temporary name and renamed,
//! so a checkpoint cut short never leaves a file that reads as complete.

use crate::payload::{PROTOCOL_VERSION, Role};
use serde::{Deserialize, Serialize, de::DeserializeOwned};
use std::path::{Path, PathBuf};

/// Where a server keeps its checkpoints and whether it starts from one; the
/// orchestrator passes them as `--checkpoints DIR` and `--restore DIR` after the run id
/// and scene of `couplet fluid-server` / `couplet dem-server`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StateDirs {
    /// Root of this run's checkpoints: `Checkpoint` commands write under it. None: the
    /// server refuses them.
    pub checkpoints: Option<PathBuf>,
    /// A checkpoint folder (`ROOT/step-<n>`) to start from instead of the scene's
    /// initial state.
    pub restore: Option<PathBuf>,
}

impl StateDirs {
    /// The command-line form, for the orchestrator to pass on.
    pub fn to_args(&self) -> Vec<std::ffi::OsString> {
        let mut out = Vec::new();
        for (flag, dir) in [
            ("--checkpoints", &self.checkpoints),
            ("--restore", &self.restore),
        ] {
            if let Some(d) = dir {
                out.push(flag.into());
                out.push(d.clone().into_os_string());
            }
        }
        out
    }

    /// Parses what [`Self::to_args`] wrote (the standalone server binaries).
    pub fn from_args(args: &[String]) -> Result<Self, String> {
        let mut dirs = Self::default();
        let mut it = args.iter();
        while let Some(flag) = it.next() {
            let slot = match flag.as_str() {
                "--checkpoints" => &mut dirs.checkpoints,
                "--restore" => &mut dirs.restore,
                other => {
                    return Err(format!(
                        "unknown argument {other:?}: expected --checkpoints DIR or --restore DIR"
                    ));
                }
            };
            let dir = it.next().ok_or_else(|| format!("{flag} needs a folder"))?;
            *slot = Some(PathBuf::from(dir));
        }
        Ok(dirs)
    }
}

/// First bytes of every state file.
pub const STATE_MAGIC: [u8; 8] = *b"CPLTSTAT";

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StateHeader {
    pub magic: [u8; 8],
    pub protocol_version: u32,
    /// [`Role`] as u32.
    pub role: u32,
    /// Index of the window the state is the start of.
    pub step: u64,
    /// Simulated time of that boundary, s.
    pub time: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot encode the {role} state: {detail}")]
    Encode {
        path: PathBuf,
        role: &'static str,
        detail: String,
    },
    #[error("{path}: not a {role} state file of this protocol: {detail}")]
    Decode {
        path: PathBuf,
        role: &'static str,
        detail: String,
    },
}

/// The folder of the checkpoint at the boundary before window `step`.
pub fn checkpoint_dir(root: &Path, step: u64) -> PathBuf {
    root.join(format!("step-{step:08}"))
}

/// The state file of `role` in checkpoint folder `dir`.
pub fn state_file(dir: &Path, role: Role) -> PathBuf {
    dir.join(format!("{}.state", role.name()))
}

fn config() -> impl bincode::config::Config {
    bincode::config::standard()
}

/// Writes `state` of `role` at the boundary before window `step` (time `time`) to `path`.
pub fn write_state<T: Serialize>(
    path: &Path,
    role: Role,
    step: u64,
    time: f64,
    state: &T,
) -> Result<(), StateError> {
    let encode_err = |e: bincode::error::EncodeError| StateError::Encode {
        path: path.to_owned(),
        role: role.name(),
        detail: e.to_string(),
    };
    let header = StateHeader {
        magic: STATE_MAGIC,
        protocol_version: PROTOCOL_VERSION,
        role: role as u32,
        step,
        time,
    };
    let mut bytes = bincode::serde::encode_to_vec(header, config()).map_err(encode_err)?;
    bytes.extend(bincode::serde::encode_to_vec(state, config()).map_err(encode_err)?);
    let io = |source| StateError::Io {
        path: path.to_owned(),
        source,
    };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let tmp = path.with_extension("state.partial");
    std::fs::write(&tmp, &bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// Reads the state of `role` from `path`: its header and the state.
pub fn read_state<T: DeserializeOwned>(
    path: &Path,
    role: Role,
) -> Result<(StateHeader, T), StateError> {
    let bytes = std::fs::read(path).map_err(|source| StateError::Io {
        path: path.to_owned(),
        source,
    })?;
    let bad = |detail: String| StateError::Decode {
        path: path.to_owned(),
        role: role.name(),
        detail,
    };
    let (header, used): (StateHeader, usize) =
        bincode::serde::decode_from_slice(&bytes, config()).map_err(|e| bad(e.to_string()))?;
    if header.magic != STATE_MAGIC {
        return Err(bad("no couplet state header".into()));
    }
    if header.protocol_version != PROTOCOL_VERSION {
        return Err(bad(format!(
            "written by protocol {}, this build speaks {PROTOCOL_VERSION}",
            header.protocol_version
        )));
    }
    if header.role != role as u32 {
        return Err(bad(format!(
            "it holds the state of {}",
            Role::from_u32(header.role).map_or("an unknown role", Role::name)
        )));
    }
    let (state, rest): (T, usize) = bincode::serde::decode_from_slice(&bytes[used..], config())
        .map_err(|e| bad(e.to_string()))?;
    if used + rest != bytes.len() {
        return Err(bad(format!(
            "{} bytes left over after the state",
            bytes.len() - used - rest
        )));
    }
    Ok((header, state))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_state_reads_back_and_a_wrong_role_or_cut_file_is_refused() {
        let dir = tempfile_dir();
        let path = state_file(&checkpoint_dir(&dir, 7), Role::Dem);
        let state = (vec![1.5f64, -2.25], String::from("spheres"));
        write_state(&path, Role::Dem, 7, 0.035, &state).unwrap();
        let (h, back): (StateHeader, (Vec<f64>, String)) = read_state(&path, Role::Dem).unwrap();
        assert_eq!((h.step, h.time), (7, 0.035));
        assert_eq!(back, state);
        let wrong = read_state::<(Vec<f64>, String)>(&path, Role::Fluid).unwrap_err();
        assert!(wrong.to_string().contains("dem-server"), "{wrong}");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        assert!(read_state::<(Vec<f64>, String)>(&path, Role::Dem).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn state_dirs_round_trip_through_arguments() {
        let dirs = StateDirs {
            checkpoints: Some("/tmp/run/checkpoints".into()),
            restore: Some("/tmp/old/checkpoints/step-00000040".into()),
        };
        let args: Vec<String> = (dirs.to_args().into_iter())
            .map(|a| a.into_string().unwrap())
            .collect();
        assert_eq!(StateDirs::from_args(&args).unwrap(), dirs);
        assert!(StateDirs::from_args(&["--resume".into(), "x".into()]).is_err());
        assert!(StateDirs::from_args(&["--restore".into()]).is_err());
    }

    fn tempfile_dir() -> PathBuf {
        let d = std::env::temp_dir().join(format!("couplet-state-test-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }
}
