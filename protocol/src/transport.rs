//! iceoryx2 ports for couplet's services and the spin-then-block wait the design asks for.
//!
//! Every windowed service is publish–subscribe of `[T]` with a [`WindowHeader`] user
//! header; single-value control services ([`Command`], [`Hello`], [`SideReport`]) carry
//! one `T`. Waking uses one event service per receiving process: a sender notifies the
//! receiver's wake event after it sends, and the receiver spins on its subscribers for
//! [`SPIN`] before it blocks on that event. Notifications are counted, so one that
//! arrives between a poll and the block is not lost.

use crate::payload::{Command, Hello, SideReport, WindowHeader};
use crate::service::{ServiceLeaf, service_name};
use crate::validate::{ValidationError, validate_header};
use core::fmt::Debug;
use iceoryx2::node::{NodeState, NodeView};
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use std::time::{Duration, Instant};

/// The iceoryx2 service flavour: inter-process, shared memory.
pub type Svc = ipc::Service;

/// An opened publish–subscribe service of payload `P` and user header `H`.
type PubSubService<P, H> =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, P, H>;

/// How long a waiting process spins before it blocks on its wake event. A zero-copy hop
/// costs ≈ 0.5 µs when the reader spins and ≈ 50 µs through an event wake-up on a small
/// VM (BENCHMARKS.md), so a window that is answered within this time pays microseconds;
/// a side that waits longer (the fluid while the DEM steps) gives its core back.
pub const SPIN: Duration = Duration::from_micros(200);

/// How long one block on the wake event lasts before the waiter checks that its peer
/// is still alive; bounds the detection time of a dead peer.
pub const BLOCK_SLICE: Duration = Duration::from_millis(100);

/// Subscriber buffer depth: a window produces one sample per service; 4 leaves room
/// for a late reader without the publisher ever blocking.
const BUFFER: usize = 4;

#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("iceoryx2 {what} on `{service}`: {detail}")]
    Ipc {
        what: &'static str,
        service: String,
        detail: String,
    },
    #[error("invalid message on `{service}`: {source}")]
    Invalid {
        service: String,
        source: ValidationError,
    },
    #[error("`{service}`: expected window {expected}, received {got}")]
    OutOfSequence {
        service: String,
        expected: u64,
        got: u64,
    },
    #[error("{0}")]
    PeerGone(String),
}

fn ipc<'a, E: Debug>(
    what: &'static str,
    service: &'a str,
) -> impl FnOnce(E) -> TransportError + 'a {
    move |e| TransportError::Ipc {
        what,
        service: service.to_owned(),
        detail: format!("{e:?}"),
    }
}

/// One process's iceoryx2 node plus the run id its services live under.
pub struct Endpoint {
    pub node: Node<Svc>,
    pub run_id: String,
}

impl Endpoint {
    pub fn new(run_id: &str) -> Result<Self, TransportError> {
        Self::create(run_id, None)
    }

    /// An endpoint whose iceoryx2 node is named [`node_name`]`(run_id, who)`, so that a
    /// peer that did not start this process can tell whether it is alive ([`node_alive`]).
    pub fn named(run_id: &str, who: &str) -> Result<Self, TransportError> {
        Self::create(run_id, Some(&node_name(run_id, who)))
    }

    fn create(run_id: &str, name: Option<&str>) -> Result<Self, TransportError> {
        quiet();
        // The orchestrator supervises the children and handles their signals.
        let mut builder = NodeBuilder::new().signal_handling_mode(SignalHandlingMode::Disabled);
        if let Some(name) = name {
            let n = NodeName::new(name).map_err(ipc("node name", name))?;
            builder = builder.name(&n);
        }
        let node = builder
            .create::<Svc>()
            .map_err(ipc("node creation", run_id))?;
        Ok(Self {
            node,
            run_id: run_id.to_owned(),
        })
    }

    fn name(&self, leaf: ServiceLeaf) -> Result<(String, ServiceName), TransportError> {
        let s = service_name(&self.run_id, leaf);
        let n = ServiceName::new(&s).map_err(ipc("service name", &s))?;
        Ok((s, n))
    }

    /// The windowed service of `leaf`: `[T]` slices under a [`WindowHeader`]. Sender and
    /// receiver open it through here, so whichever comes first creates it with what the
    /// other asks for (iceoryx2 refuses an open that asks for more than the creator set:
    /// another payload or header, more publishers, a deeper buffer).
    fn slice_service<T: ZeroCopySend + Debug + Copy + 'static>(
        &self,
        leaf: ServiceLeaf,
    ) -> Result<(String, PubSubService<[T], WindowHeader>), TransportError> {
        let (s, n) = self.name(leaf)?;
        let service = self
            .node
            .service_builder(&n)
            .publish_subscribe::<[T]>()
            .user_header::<WindowHeader>()
            .subscriber_max_buffer_size(BUFFER)
            .open_or_create()
            .map_err(ipc("open service", &s))?;
        Ok((s, service))
    }

    /// The single-value service of `leaf` (control messages), opened alike by sender and
    /// receiver as [`Self::slice_service`]; up to four publishers.
    fn value_service<T: ZeroCopySend + Debug + Copy + 'static>(
        &self,
        leaf: ServiceLeaf,
    ) -> Result<(String, PubSubService<T, ()>), TransportError> {
        let (s, n) = self.name(leaf)?;
        let service = self
            .node
            .service_builder(&n)
            .publish_subscribe::<T>()
            .subscriber_max_buffer_size(BUFFER)
            .max_publishers(4)
            .open_or_create()
            .map_err(ipc("open service", &s))?;
        Ok((s, service))
    }

    /// Publisher of `[T]` slices with at most `max_len` elements at first (the
    /// publisher reallocates, power of two, if more are sent later).
    pub fn slice_sender<T: ZeroCopySend + Debug + Copy + 'static>(
        &self,
        leaf: ServiceLeaf,
        max_len: usize,
    ) -> Result<SliceSender<T>, TransportError> {
        let (s, service) = self.slice_service::<T>(leaf)?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(max_len.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(ipc("publisher creation", &s))?;
        Ok(SliceSender {
            publisher,
            service: s,
        })
    }

    pub fn slice_receiver<T: ZeroCopySend + Debug + Copy + 'static>(
        &self,
        leaf: ServiceLeaf,
    ) -> Result<SliceReceiver<T>, TransportError> {
        let (s, service) = self.slice_service::<T>(leaf)?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(ipc("subscriber creation", &s))?;
        Ok(SliceReceiver {
            subscriber,
            service: s,
        })
    }

    pub fn value_sender<T: ZeroCopySend + Debug + Copy + 'static>(
        &self,
        leaf: ServiceLeaf,
    ) -> Result<ValueSender<T>, TransportError> {
        let (s, service) = self.value_service::<T>(leaf)?;
        let publisher = service
            .publisher_builder()
            .create()
            .map_err(ipc("publisher creation", &s))?;
        Ok(ValueSender {
            publisher,
            service: s,
        })
    }

    pub fn value_receiver<T: ZeroCopySend + Debug + Copy + 'static>(
        &self,
        leaf: ServiceLeaf,
    ) -> Result<ValueReceiver<T>, TransportError> {
        let (s, service) = self.value_service::<T>(leaf)?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(ipc("subscriber creation", &s))?;
        Ok(ValueReceiver {
            subscriber,
            service: s,
        })
    }

    /// The event service of `leaf`, opened alike by its listener and its notifiers.
    fn event_service(
        &self,
        leaf: ServiceLeaf,
    ) -> Result<
        (
            String,
            iceoryx2::service::port_factory::event::PortFactory<Svc>,
        ),
        TransportError,
    > {
        let (s, n) = self.name(leaf)?;
        let event = self
            .node
            .service_builder(&n)
            .event()
            .open_or_create()
            .map_err(ipc("open event", &s))?;
        Ok((s, event))
    }

    /// The wake event of a process (`leaf` is one of the `*Wake` leaves): a listener
    /// for its owner.
    pub fn wake_listener(&self, leaf: ServiceLeaf) -> Result<WakeListener, TransportError> {
        let (s, event) = self.event_service(leaf)?;
        let listener = event
            .listener_builder()
            .create()
            .map_err(ipc("listener creation", &s))?;
        Ok(WakeListener {
            listener,
            service: s,
        })
    }

    /// A notifier that wakes the owner of `leaf`.
    pub fn waker(&self, leaf: ServiceLeaf) -> Result<Waker, TransportError> {
        let (s, event) = self.event_service(leaf)?;
        let notifier = event
            .notifier_builder()
            .create()
            .map_err(ipc("notifier creation", &s))?;
        Ok(Waker {
            notifier,
            service: s,
        })
    }
}

pub struct SliceSender<T: ZeroCopySend + Debug + Copy + 'static> {
    publisher: Publisher<Svc, [T], WindowHeader>,
    service: String,
}

impl<T: ZeroCopySend + Debug + Copy + 'static> SliceSender<T> {
    /// Copies `data` into a loaned shared-memory slice and sends it with `header`
    /// (its `count` is set from `data`).
    pub fn send(&self, mut header: WindowHeader, data: &[T]) -> Result<(), TransportError> {
        header.count = data.len() as u32;
        header.sent_ns = crate::payload::monotonic_ns();
        let mut sample = self
            .publisher
            .loan_slice_uninit(data.len())
            .map_err(ipc("loan", &self.service))?;
        *sample.user_header_mut() = header;
        let sample = sample.write_from_slice(data);
        sample.send().map_err(ipc("send", &self.service))?;
        Ok(())
    }
}

/// A received, validated slice sample.
pub type SliceSample<T> = iceoryx2::sample::Sample<Svc, [T], WindowHeader>;

pub struct SliceReceiver<T: ZeroCopySend + Debug + Copy + 'static> {
    subscriber: Subscriber<Svc, [T], WindowHeader>,
    pub service: String,
}

impl<T: ZeroCopySend + Debug + Copy + 'static> SliceReceiver<T> {
    /// The newest sample, if any arrived, with its header checked (version, count).
    pub fn try_latest(&self) -> Result<Option<SliceSample<T>>, TransportError> {
        let mut latest = None;
        while let Some(s) = self
            .subscriber
            .receive()
            .map_err(ipc("receive", &self.service))?
        {
            latest = Some(s);
        }
        if let Some(s) = &latest {
            validate_header(leaf_of(&self.service), s.user_header(), s.payload().len()).map_err(
                |source| TransportError::Invalid {
                    service: self.service.clone(),
                    source,
                },
            )?;
        }
        Ok(latest)
    }

    /// Like [`Self::try_latest`] but insists on window `step`: an older one is skipped,
    /// a newer one is an error (the peers are out of lockstep).
    pub fn try_step(&self, step: u64) -> Result<Option<SliceSample<T>>, TransportError> {
        match self.try_latest()? {
            Some(s) if s.user_header().step == step => Ok(Some(s)),
            Some(s) if s.user_header().step > step => Err(TransportError::OutOfSequence {
                service: self.service.clone(),
                expected: step,
                got: s.user_header().step,
            }),
            _ => Ok(None),
        }
    }
}

fn leaf_of(service: &str) -> &'static str {
    // Validation errors carry a static name; the service's last segment is enough.
    match service.rsplit('/').next() {
        Some("points") => "points",
        Some("bodies") => "bodies",
        Some("loads") => "loads",
        Some("particles") => "particles",
        _ => "sample",
    }
}

pub struct ValueSender<T: ZeroCopySend + Debug + Copy + 'static> {
    publisher: Publisher<Svc, T, ()>,
    service: String,
}

impl<T: ZeroCopySend + Debug + Copy + 'static> ValueSender<T> {
    pub fn send(&self, value: T) -> Result<(), TransportError> {
        self.publisher
            .send_copy(value)
            .map_err(ipc("send", &self.service))?;
        Ok(())
    }
}

pub struct ValueReceiver<T: ZeroCopySend + Debug + Copy + 'static> {
    subscriber: Subscriber<Svc, T, ()>,
    pub service: String,
}

impl<T: ZeroCopySend + Debug + Copy + 'static> ValueReceiver<T> {
    pub fn try_next(&self) -> Result<Option<T>, TransportError> {
        Ok(self
            .subscriber
            .receive()
            .map_err(ipc("receive", &self.service))?
            .map(|s| *s.payload()))
    }
}

pub struct Waker {
    notifier: Notifier<Svc>,
    service: String,
}

impl Waker {
    pub fn wake(&self) -> Result<(), TransportError> {
        self.notifier
            .notify()
            .map_err(ipc("notify", &self.service))?;
        Ok(())
    }
}

pub struct WakeListener {
    listener: Listener<Svc>,
    service: String,
}

impl WakeListener {
    /// Spin-then-block: calls `poll` until it yields a value, spinning for [`SPIN`],
    /// then blocking on this wake event in slices of [`BLOCK_SLICE`]; after each slice
    /// `alive` is asked whether waiting still makes sense (it returns an error naming
    /// the dead peer, or the time-out).
    pub fn wait_for<R>(
        &self,
        mut poll: impl FnMut() -> Result<Option<R>, TransportError>,
        mut alive: impl FnMut() -> Result<(), TransportError>,
    ) -> Result<R, TransportError> {
        let start = Instant::now();
        loop {
            if let Some(r) = poll()? {
                return Ok(r);
            }
            if start.elapsed() < SPIN {
                core::hint::spin_loop();
                continue;
            }
            match self.listener.timed_wait(|_| {}, BLOCK_SLICE) {
                // A signal the process handles (the orchestrator's Ctrl-C, `interrupt.rs`)
                // cuts the wait short: a slice like any other, not a failure.
                Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                Err(e) => return Err(ipc("wait", &self.service)(e)),
            }
            alive()?;
        }
    }
}

/// A server's side of the control channel after its ports exist: the hello it has said
/// and the commands that come after it.
pub struct Inbox<'a> {
    commands: ValueReceiver<Command>,
    /// Kept for the whole run: a dropped publisher takes its undelivered samples with it.
    hello: ValueSender<Hello>,
    greeting: Hello,
    wake: &'a WakeListener,
    wake_orchestrator: &'a Waker,
    orchestrator: &'a Orchestrator,
    heard: bool,
}

impl<'a> Inbox<'a> {
    /// Says `greeting` to the orchestrator and wakes it. Call it last: once the
    /// orchestrator has the hello, every port of this process must exist.
    pub fn greet(
        ep: &Endpoint,
        greeting: Hello,
        wake: &'a WakeListener,
        wake_orchestrator: &'a Waker,
        orchestrator: &'a Orchestrator,
    ) -> Result<Self, TransportError> {
        let commands = Control::command_receiver(ep)?;
        let hello = Control::hello_sender(ep)?;
        hello.send(greeting)?;
        wake_orchestrator.wake()?;
        Ok(Inbox {
            commands,
            hello,
            greeting,
            wake,
            wake_orchestrator,
            orchestrator,
            heard: false,
        })
    }

    /// The next command, waited for on `wake`; an error once the orchestrator is gone.
    /// Started apart ([`Orchestrator::is_detached`]), a server may say hello before the
    /// orchestrator listens, and a hello sent to no subscriber is lost: until the first
    /// command shows that it was heard, it is said again every wait slice.
    pub fn next_command(&mut self) -> Result<Command, TransportError> {
        let orchestrator = self.orchestrator;
        let command = if orchestrator.is_detached() && !self.heard {
            let (hello, greeting, wake) = (&self.hello, self.greeting, self.wake_orchestrator);
            self.wake.wait_for(
                || self.commands.try_next(),
                || {
                    orchestrator.check()?;
                    hello.send(greeting)?;
                    wake.wake()
                },
            )?
        } else {
            (self.wake).wait_for(|| self.commands.try_next(), || orchestrator.check())?
        };
        self.heard = true;
        Ok(command)
    }
}

/// Typed helpers over the control services, shared by all three roles.
pub struct Control;

impl Control {
    pub fn hello_sender(ep: &Endpoint) -> Result<ValueSender<Hello>, TransportError> {
        ep.value_sender(ServiceLeaf::Hello)
    }
    pub fn command_receiver(ep: &Endpoint) -> Result<ValueReceiver<Command>, TransportError> {
        ep.value_receiver(ServiceLeaf::Command)
    }
    pub fn report_sender(ep: &Endpoint) -> Result<ValueSender<SideReport>, TransportError> {
        ep.value_sender(ServiceLeaf::Report)
    }
}

/// iceoryx2 warns that it runs on its default config; couplet means it to.
/// `IOX2_LOG_LEVEL` still overrides this for debugging.
fn quiet() {
    set_log_level_from_env_or(LogLevel::Error);
}

/// The iceoryx2 node name of process `who` (a [`Role`] name) of run `run_id`.
pub fn node_name(run_id: &str, who: &str) -> String {
    format!("couplet/{run_id}/{who}")
}

/// Whether process `who` of run `run_id` holds a live iceoryx2 node ([`Endpoint::named`]).
/// iceoryx2 tells a live node from one whose process died by a lock that the process
/// holds on the node's monitor file, so this needs no parent–child relation: only the
/// same kernel and the same iceoryx2 directory (`/tmp/iceoryx2`).
pub fn node_alive(run_id: &str, who: &str) -> Result<bool, TransportError> {
    quiet();
    let name = node_name(run_id, who);
    let mut alive = false;
    Node::<Svc>::list(Config::global_config(), |state| {
        if let NodeState::Alive(view) = &state
            && view
                .details()
                .as_ref()
                .is_some_and(|d| d.name().as_str() == name)
        {
            alive = true;
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    })
    .map_err(ipc("node list", &name))?;
    Ok(alive)
}

/// How long a server started apart from its orchestrator waits for it to appear, and an
/// orchestrator for such a server's hello (GPU set-up of a large scene takes minutes).
pub const DETACHED_PATIENCE: Duration = Duration::from_secs(300);

/// How a server knows that its orchestrator is still there.
#[derive(Debug)]
pub enum Orchestrator {
    /// The orchestrator started this process: the parent pid changes when it exits.
    Parent(u32),
    /// Started apart (`--detached`: another container): the orchestrator's iceoryx2 node
    /// of the run. It may appear up to [`DETACHED_PATIENCE`] after this server; once seen,
    /// its disappearance ends the server.
    Detached {
        run_id: String,
        since: Instant,
        seen: core::sync::atomic::AtomicBool,
    },
}

impl Orchestrator {
    /// This process's parent is its orchestrator.
    pub fn parent() -> Self {
        Self::Parent(std::os::unix::process::parent_id())
    }

    /// The orchestrator of `run_id` runs apart from this process.
    pub fn detached(run_id: &str) -> Self {
        Self::Detached {
            run_id: run_id.to_owned(),
            since: Instant::now(),
            seen: core::sync::atomic::AtomicBool::new(false),
        }
    }

    pub fn is_detached(&self) -> bool {
        matches!(self, Self::Detached { .. })
    }

    /// An error once the orchestrator has gone (or, detached, never came).
    pub fn check(&self) -> Result<(), TransportError> {
        match self {
            Self::Parent(pid) => parent_alive(*pid),
            Self::Detached {
                run_id,
                since,
                seen,
            } => {
                if node_alive(run_id, crate::Role::Orchestrator.name())? {
                    seen.store(true, core::sync::atomic::Ordering::Relaxed);
                    Ok(())
                } else if seen.load(core::sync::atomic::Ordering::Relaxed) {
                    Err(TransportError::PeerGone(format!(
                        "the orchestrator of run {run_id} has exited (its iceoryx2 node is gone)"
                    )))
                } else if since.elapsed() > DETACHED_PATIENCE {
                    Err(TransportError::PeerGone(format!(
                        "no orchestrator for run {run_id} within {DETACHED_PATIENCE:?}: start `couplet run SCENE --run-id {run_id} --external …`"
                    )))
                } else {
                    Ok(())
                }
            }
        }
    }
}

/// Returns an error once the process that started this one has gone (its parent pid
/// changed): a server must not outlive its orchestrator.
pub fn parent_alive(original_parent: u32) -> Result<(), TransportError> {
    if std::os::unix::process::parent_id() == original_parent {
        Ok(())
    } else {
        Err(TransportError::PeerGone(format!(
            "the orchestrator (pid {original_parent}) has exited"
        )))
    }
}
