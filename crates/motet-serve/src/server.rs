//! The server process's parts: the session behind a lock, a clock thread
//! that ticks it on the wall clock, and a task that pushes the machine's
//! status to WebSocket clients.

use crate::engine::Nodes;
use crate::events::Level;
use crate::jobs::JobStore;
use crate::persist;
use crate::session::{Session, State};
use motet_host::Machine;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::sync::broadcast;

/// Status pushes to WebSocket clients, µs apart.
pub const PUSH_INTERVAL_US: u64 = 20_000;
/// Longest the clock thread sleeps while the machine moves, µs.
const ACTIVE_TICK_US: u64 = 1_000;
/// Longest it sleeps while nothing moves, µs.
const IDLE_TICK_US: u64 = 50_000;

/// How a server is set up.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// Address to listen on (loopback unless the person says otherwise).
    pub listen: SocketAddr,
    /// The server's own folder: uploads and the token.
    pub dir: PathBuf,
    /// Required on every request when set.
    pub token: Option<String>,
}

/// What the HTTP side shares with the clock thread.
pub(crate) struct Shared {
    pub(crate) session: Mutex<Session>,
    pub(crate) jobs: Mutex<JobStore>,
    pub(crate) machine: Arc<Machine>,
    pub(crate) token: Option<String>,
    pub(crate) started: Instant,
    pub(crate) updates: broadcast::Sender<Arc<str>>,
    /// Something a screen should see at once happened (an event: a stop,
    /// a state change): the pusher sends without waiting for its tick.
    pub(crate) changed: tokio::sync::Notify,
    /// The server's folder (uploads, the token, the kept state).
    dir: PathBuf,
    /// Serialises writes of the kept state.
    saving: Mutex<()>,
    /// The graph driving the machine by hand, if one does.
    pub(crate) graph: std::sync::OnceLock<crate::graph::GraphRun>,
    stop: AtomicBool,
    driver: Mutex<Option<std::thread::Thread>>,
}

impl Shared {
    /// Server time, µs since it started.
    pub(crate) fn now(&self) -> u64 {
        self.started.elapsed().as_micros() as u64
    }

    /// The session, ticked to now. A lock poisoned by a panic elsewhere is
    /// taken anyway: the session's own state is always whole between calls.
    pub(crate) fn session(&self) -> MutexGuard<'_, Session> {
        let mut s = self.session.lock().unwrap_or_else(|e| e.into_inner());
        s.tick(self.now());
        s
    }

    pub(crate) fn jobs(&self) -> MutexGuard<'_, JobStore> {
        self.jobs.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Writes what the server keeps across restarts (the jobs, the queue,
    /// the history). The session and the job store are locked one after
    /// the other, never together. A failed write is an event: the server
    /// goes on, and the next change writes again.
    pub(crate) fn save(&self) {
        let _one = self.saving.lock().unwrap_or_else(|e| e.into_inner());
        let (queue, history) = {
            let s = self.session.lock().unwrap_or_else(|e| e.into_inner());
            (s.queued_ids(), s.history().cloned().collect())
        };
        let (next, jobs) = {
            let j = self.jobs();
            (j.next_id(), j.saved())
        };
        let saved = persist::Saved::new(next, jobs, queue, history);
        if let Err(e) = persist::store(&self.dir, &saved) {
            let mut s = self.session.lock().unwrap_or_else(|e| e.into_inner());
            let now = s.status().t_us;
            s.events.push(
                now,
                Level::Error,
                format!(
                    "cannot keep the jobs and history in {}: {e}",
                    self.dir.display()
                ),
            );
        }
    }

    /// The server is shutting down: threads serving it end.
    pub(crate) fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Wakes the clock thread (an action started motion).
    pub(crate) fn wake(&self) {
        if let Some(t) = self
            .driver
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
        {
            t.unpark();
        }
    }
}

/// A running server: the session ticking on the wall clock.
pub struct Server {
    pub(crate) shared: Arc<Shared>,
    driver: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Starts the clock thread for `machine` on `nodes`; uploads go under
    /// `cfg.dir`.
    pub fn start(
        machine: Machine,
        mut nodes: Box<dyn Nodes>,
        cfg: &ServerConfig,
    ) -> std::io::Result<Server> {
        // Server time (`Shared::now`) from here; the nodes' links stamp
        // their frames' arrival on it.
        let started = Instant::now();
        nodes.stamp_arrivals(motet_link::WallClock::since(started));
        let machine = Arc::new(machine);
        let (updates, _) = broadcast::channel(64);
        let mut session = Session::new(machine.clone(), nodes);
        let mut jobs = JobStore::new(&cfg.dir)?;
        restore(&cfg.dir, &machine, &mut session, &mut jobs);
        let shared = Arc::new(Shared {
            session: Mutex::new(session),
            jobs: Mutex::new(jobs),
            machine,
            token: cfg.token.clone(),
            started,
            updates,
            changed: tokio::sync::Notify::new(),
            dir: cfg.dir.clone(),
            saving: Mutex::new(()),
            graph: std::sync::OnceLock::new(),
            stop: AtomicBool::new(false),
            driver: Mutex::new(None),
        });
        let s = shared.clone();
        let driver = std::thread::Builder::new()
            .name("motet-clock".into())
            .spawn(move || drive(&s))?;
        *shared.driver.lock().unwrap_or_else(|e| e.into_inner()) = Some(driver.thread().clone());
        Ok(Server {
            shared,
            driver: Some(driver),
        })
    }

    /// Drives the machine by hand through `graph` from now on: it runs on a
    /// simulated node, paced to the wall clock, its inputs set over the API
    /// (`/api/graph`); the session takes no jobs meanwhile.
    pub fn drive_by_graph(
        &self,
        graph: motet_graph::GraphFile,
    ) -> Result<(), crate::graph::StartError> {
        let file = graph.file.clone();
        let run = crate::graph::GraphRun::start(self.shared.machine.as_ref().clone(), graph)?;
        if self.shared.graph.set(run).is_err() {
            return Err(std::io::Error::other("a graph drives this machine already").into());
        }
        self.shared.session().hand_driven(&file);
        Ok(())
    }

    /// The HTTP routes, the page and the WebSocket.
    pub fn router(&self) -> axum::Router {
        crate::http::router(self.shared.clone())
    }

    /// Serves on `listener` until `shutdown` resolves; then the machine is
    /// stopped on its path before the process goes.
    pub async fn serve(
        mut self,
        listener: tokio::net::TcpListener,
        shutdown: impl std::future::Future<Output = ()> + Send + 'static,
    ) -> std::io::Result<()> {
        let pusher = tokio::spawn(crate::http::push_status(self.shared.clone()));
        let app = self.router();
        let served = axum::serve(listener, app)
            .with_graceful_shutdown(shutdown)
            .await;
        pusher.abort();
        self.finish();
        served
    }

    /// Stops the machine on its path (if it moves) and the clock thread.
    fn finish(&mut self) {
        {
            let mut s = self.shared.session();
            s.estop();
        }
        // Let the nodes brake to rest on their tails (a few hundred ms).
        let until = Instant::now() + Duration::from_secs(3);
        while Instant::now() < until {
            if matches!(
                self.shared.session().state(),
                State::Stopped | State::Idle | State::Alarm
            ) {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        self.shared.stop.store(true, Ordering::Relaxed);
        self.shared.wake();
        if let Some(d) = self.driver.take() {
            let _ = d.join();
        }
    }
}

/// Puts back what the server kept before it restarted; whatever cannot be
/// read is said in the events and left on disk.
fn restore(dir: &std::path::Path, machine: &Machine, s: &mut Session, jobs: &mut JobStore) {
    let saved = match persist::load(dir) {
        Ok(Some(saved)) => saved,
        Ok(None) => return,
        Err(e) => {
            let aside = persist::set_aside(dir).map_or_else(
                |e| format!(" (not set aside: {e})"),
                |p| format!(", set aside as {}", p.display()),
            );
            s.events
                .push(0, Level::Error, format!("kept state not read: {e}{aside}"));
            return;
        }
    };
    for problem in jobs.restore(machine, &saved.jobs, saved.next_job) {
        s.events.push(
            0,
            Level::Warn,
            format!("kept job not read again: {problem}"),
        );
    }
    let queued: Vec<_> = saved.queue.iter().filter_map(|&id| jobs.get(id)).collect();
    s.events.push(
        0,
        Level::Info,
        format!(
            "kept from before: {} jobs, {} queued, {} in the history",
            jobs.list().len(),
            queued.len(),
            saved.history.len()
        ),
    );
    s.restore_queue(queued);
    s.restore_history(saved.history);
}

/// The clock thread: ticks the session as often as its run needs.
fn drive(shared: &Shared) {
    let mut seen = 0;
    let mut saved = 0;
    while !shared.stop.load(Ordering::Relaxed) {
        let now = shared.now();
        let (next, busy) = {
            let mut s = shared.session.lock().unwrap_or_else(|e| e.into_inner());
            let next = s.tick(now);
            if s.events.last_seq() != seen {
                seen = s.events.last_seq();
                shared.changed.notify_one();
            }
            let version = s.saved_version();
            if version != saved {
                saved = version;
                drop(s);
                shared.save();
                s = shared.session.lock().unwrap_or_else(|e| e.into_inner());
            }
            let resting = matches!(
                s.state(),
                State::Idle | State::Stopped | State::Alarm | State::Paused
            );
            (next, !resting || s.status_connecting())
        };
        // At rest only the clock exchanges (every few hundred ms) are due:
        // a run's own wakeups (every ms) matter only while it moves or
        // connects.
        let wait = if busy {
            next.saturating_sub(shared.now()).clamp(100, ACTIVE_TICK_US)
        } else {
            IDLE_TICK_US
        };
        std::thread::park_timeout(Duration::from_micros(wait));
    }
}
