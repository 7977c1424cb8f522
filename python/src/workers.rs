//! Planning threads kept between plans: a job goes to an idle worker, or to a new one when all
//! are busy (plans from several Python threads run in parallel), and a worker that finishes
//! waits for the next job unless [`MAX_IDLE`] are already waiting. Own code rather than a pool
//! crate: the fixed-size pools (rayon, threadpool) would queue concurrent plans behind each other.

use std::sync::mpsc;
use std::sync::Mutex;

/// A unit of work for a worker: it must not unwind (the caller catches panics inside it).
pub type Job = Box<dyn FnOnce() + Send + 'static>;

/// Idle workers kept at most; more finish with their job.
const MAX_IDLE: usize = 4;

/// The idle workers' job queues (each worker has its own).
static IDLE: Mutex<Vec<mpsc::Sender<Job>>> = Mutex::new(Vec::new());

/// Runs `job` on an idle worker or on a new thread.
pub fn run(job: Job) -> std::io::Result<()> {
    let mut job = job;
    loop {
        let idle = IDLE.lock().map(|mut v| v.pop()).unwrap_or(None);
        let Some(worker) = idle else { break };
        match worker.send(job) {
            Ok(()) => return Ok(()),
            // that worker has ended: try the next one
            Err(mpsc::SendError(back)) => job = back,
        }
    }
    let (tx, rx) = mpsc::channel::<Job>();
    std::thread::Builder::new()
        .name("cellsar-plan".into())
        .spawn(move || serve(tx, rx, job))
        .map(drop)
}

/// A worker's life: the first job, then every job handed to it while it is idle.
fn serve(me: mpsc::Sender<Job>, jobs: mpsc::Receiver<Job>, first: Job) {
    first();
    loop {
        let parked = match IDLE.lock() {
            Ok(mut idle) if idle.len() < MAX_IDLE => {
                idle.push(me.clone());
                true
            }
            _ => false,
        };
        if !parked {
            return;
        }
        match jobs.recv() {
            Ok(job) => job(),
            Err(_) => return,
        }
    }
}
