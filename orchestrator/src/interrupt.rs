//! Ctrl-C and SIGTERM for `couplet run` and `couplet validate` where it runs cases.
//!
//! Without a handler either signal killed the orchestrator at once, leaving the recording
//! without its summary (readable only up to its last complete chunk). A background job
//! of a script ignores SIGINT, as the shell set it up, and `kill -INT` then did nothing
//! at all: a sweep so signalled ran on (session 40's note).
//!
//! [`install`] records the first signal in a flag that the coupling loop reads after
//! every window ([`crate::run::run`]): the run stops there, tells the servers to shut
//! down and closes its recording, and `couplet` exits with 128 + the signal's number
//! (130, 143), as a shell reports a process the signal killed. A second signal, half a
//! second or more after the first, ends the process at once, for a window that takes too
//! long.
//!
//! A SIGINT already ignored when the process starts stays ignored (the shell's choice for
//! a background job, so that a terminal's Ctrl-C does not reach it); such a run stops on
//! SIGTERM. Servers that `couplet run` starts ignore SIGINT ([`ignore_sigint`]): a
//! terminal's Ctrl-C goes to the whole foreground process group, and the orchestrator,
//! not they, decides when the run ends (they exit within a second of it going).

use std::sync::atomic::{AtomicI32, AtomicI64, Ordering};

/// The first signal received, 0 for none.
static RECEIVED: AtomicI32 = AtomicI32::new(0);
/// When it came, CLOCK_MONOTONIC in ns.
static RECEIVED_AT_NS: AtomicI64 = AtomicI64::new(0);

/// A signal this soon after the first is the same request delivered twice, not a second
/// one: GNU `timeout` sends its signal to the command and then to the command's whole
/// process group, which holds the command, so the orchestrator gets it twice within
/// microseconds. (Taken as the second request, that ended the process at once, and
/// `scripts/gpu-check`'s cut runs were left without their summary; 2026-11-29.) A person
/// pressing Ctrl-C again takes longer than this.
const SAME_REQUEST_NS: i64 = 500_000_000;

/// What the first signal prints (with write(2): no allocation, no lock).
const FIRST: &[u8] = b"\ncouplet: stopping once the window in progress is done (signal again, \
    after half a second, to stop at once)\n";

/// CLOCK_MONOTONIC in ns (clock_gettime(2) is async-signal-safe).
fn now_ns() -> i64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec * 1_000_000_000 + ts.tv_nsec
}

extern "C" fn note(signal: libc::c_int) {
    // Only async-signal-safe calls here: atomics, clock_gettime(2), write(2), signal(2),
    // raise(3). The handler runs with SIGINT and SIGTERM blocked, so one cannot
    // interrupt the other between the two stores.
    let now = now_ns();
    if RECEIVED
        .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
        .is_ok()
    {
        RECEIVED_AT_NS.store(now, Ordering::SeqCst);
        // SAFETY: write(2) on stderr from a static buffer is async-signal-safe.
        unsafe {
            libc::write(2, FIRST.as_ptr().cast(), FIRST.len());
        }
    } else if now - RECEIVED_AT_NS.load(Ordering::SeqCst) > SAME_REQUEST_NS {
        // SAFETY: restoring the default disposition and re-raising are async-signal-safe;
        // the signal is delivered once the handler returns and unblocks it.
        unsafe {
            libc::signal(signal, libc::SIG_DFL);
            libc::raise(signal);
        }
    }
}

/// Whether `signal`'s disposition is "ignore" now.
fn ignored(signal: libc::c_int) -> bool {
    // SAFETY: sigaction with a null new action only reads the current one into `old`.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal, std::ptr::null(), &mut old) == 0
            && old.sa_sigaction == libc::SIG_IGN
    }
}

/// Routes SIGTERM, and SIGINT unless it is ignored, to the flag [`requested`] reads.
pub fn install() -> std::io::Result<()> {
    for signal in [libc::SIGINT, libc::SIGTERM] {
        if signal == libc::SIGINT && ignored(signal) {
            continue;
        }
        // SAFETY: `note` only makes async-signal-safe calls. SA_RESTART restarts this
        // process's interrupted reads and writes (the recorder's files) instead of
        // failing them with EINTR; iceoryx2's timed wait is not restarted, and
        // `WakeListener::wait_for` takes its interruption as an ordinary slice.
        let rc = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = note as extern "C" fn(libc::c_int) as libc::sighandler_t;
            action.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut action.sa_mask);
            libc::sigaddset(&mut action.sa_mask, libc::SIGINT);
            libc::sigaddset(&mut action.sa_mask, libc::SIGTERM);
            libc::sigaction(signal, &action, std::ptr::null_mut())
        };
        if rc != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

/// Makes this process ignore SIGINT (a server that `couplet run` started).
pub fn ignore_sigint() {
    // SAFETY: setting a disposition to SIG_IGN has no handler to run.
    unsafe {
        libc::signal(libc::SIGINT, libc::SIG_IGN);
    }
}

/// A signal asking the run to stop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Interrupt(pub i32);

impl Interrupt {
    pub fn name(self) -> String {
        match self.0 {
            libc::SIGINT => "SIGINT".into(),
            libc::SIGTERM => "SIGTERM".into(),
            n => format!("signal {n}"),
        }
    }

    /// The exit code a shell gives a process this signal ended.
    pub fn exit_code(self) -> u8 {
        // Linux's signals are numbered 1 to 64, so 128 + n fits.
        u8::try_from(128 + self.0).unwrap_or(u8::MAX)
    }
}

/// The signal received since [`install`], if any.
pub fn requested() -> Option<Interrupt> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        n => Some(Interrupt(n)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_are_the_shells() {
        // bash(1), "EXIT STATUS": 128 + n for a command ended by signal n.
        assert_eq!(Interrupt(libc::SIGINT).exit_code(), 130);
        assert_eq!(Interrupt(libc::SIGTERM).exit_code(), 143);
        assert_eq!(Interrupt(libc::SIGINT).name(), "SIGINT");
    }
}
