//! SIGINT (Ctrl-C) and SIGTERM for the commands that keep what they computed when stopped
//! (`run`, `sweep`).
//!
//! The first of either signal raises one flag, [`flag`], and records which signal came
//! ([`received`]): a run takes the flag as its cancellation token and publishes its files with
//! reason `SIGINT` or `SIGTERM`; a sweep starts no new run. A second signal ends the process at
//! once (exit status 128 + the signal: 130 for Ctrl-C). The handlers are plain `sigaction`
//! handlers, because the `ctrlc` crate maps SIGINT and SIGTERM to one callback and cannot say
//! which came; they do only what a signal handler may (atomic stores, `write(2)`, `_exit`).

use std::sync::atomic::{AtomicBool, AtomicI32, AtomicPtr, AtomicUsize, Ordering};

/// Raised by the first SIGINT or SIGTERM.
static RAISED: AtomicBool = AtomicBool::new(false);
/// The first signal's number (0: none yet).
static SIGNAL: AtomicI32 = AtomicI32::new(0);
/// The line the handler prints at the first signal (a `'static` text: pointer and length).
static MESSAGE: AtomicPtr<u8> = AtomicPtr::new(std::ptr::null_mut());
static MESSAGE_LEN: AtomicUsize = AtomicUsize::new(0);

/// SIGINT's number (2 on every Unix, and the number `ctrlc` stands for elsewhere).
#[cfg(not(unix))]
const SIGINT: i32 = 2;
/// SIGTERM's number (15 on every Unix).
const SIGTERM: i32 = 15;

/// Which signal stopped the work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT: Ctrl-C.
    Interrupt,
    /// SIGTERM: `kill`, a batch system's time limit.
    Terminate,
}

impl Signal {
    /// The exit status of a command this signal stopped: 130 for Ctrl-C (the shell's code for
    /// SIGINT), 3 for SIGTERM (a stop, like a budget's).
    pub fn exit_status(self) -> u8 {
        match self {
            Signal::Interrupt => 130,
            Signal::Terminate => 3,
        }
    }
}

/// The flag the first signal raises (a run's cancellation token).
pub fn flag() -> &'static AtomicBool {
    &RAISED
}

/// The first signal received, if any.
pub fn received() -> Option<Signal> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        SIGTERM => Some(Signal::Terminate),
        _ => Some(Signal::Interrupt),
    }
}

/// Install the handlers; `message` is printed (on its own line) at the first signal. A handler
/// that cannot be installed is a warning: the signal then ends djkr as it would any program.
pub fn install(message: &'static str) {
    MESSAGE_LEN.store(message.len(), Ordering::SeqCst);
    MESSAGE.store(message.as_ptr().cast_mut(), Ordering::SeqCst);
    if let Err(e) = install_handlers() {
        eprintln!(
            "warning: signal handlers not installed ({e}): Ctrl-C or SIGTERM will end djkr \
             without keeping what it computed"
        );
    }
}

/// Record the signal; a second one ends the process.
fn on_signal(sig: i32) {
    if SIGNAL
        .compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst)
        .is_err()
    {
        exit_now(128 + sig);
    }
    RAISED.store(true, Ordering::SeqCst);
    let ptr = MESSAGE.load(Ordering::SeqCst);
    let len = MESSAGE_LEN.load(Ordering::SeqCst);
    if !ptr.is_null() {
        write_stderr(b"\n");
        // SAFETY: `ptr` and `len` describe the `'static` string given to `install`.
        write_stderr(unsafe { std::slice::from_raw_parts(ptr, len) });
        write_stderr(b"\n");
    }
}

#[cfg(unix)]
fn install_handlers() -> Result<(), String> {
    extern "C" fn handler(sig: libc::c_int) {
        on_signal(sig);
    }
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is a valid starting point; the handler is an
        // `extern "C" fn(c_int)` that only does async-signal-safe work; SA_RESTART keeps the
        // writer's system calls from failing with EINTR.
        let ok = unsafe {
            let mut sa: libc::sigaction = std::mem::zeroed();
            sa.sa_sigaction = handler as extern "C" fn(libc::c_int) as usize;
            sa.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut sa.sa_mask);
            libc::sigaction(sig, &sa, std::ptr::null_mut()) == 0
        };
        if !ok {
            return Err(std::io::Error::last_os_error().to_string());
        }
    }
    Ok(())
}

#[cfg(not(unix))]
fn install_handlers() -> Result<(), String> {
    // Elsewhere Ctrl-C (and its kin) arrive through `ctrlc` as one event: an interrupt.
    ctrlc::set_handler(|| on_signal(SIGINT)).map_err(|e| e.to_string())
}

#[cfg(unix)]
fn write_stderr(bytes: &[u8]) {
    // SAFETY: write(2) on fd 2 with a valid buffer is async-signal-safe.
    unsafe {
        libc::write(2, bytes.as_ptr().cast(), bytes.len());
    }
}

#[cfg(not(unix))]
fn write_stderr(bytes: &[u8]) {
    use std::io::Write;
    let _ = std::io::stderr().write_all(bytes);
}

#[cfg(unix)]
fn exit_now(code: i32) -> ! {
    // SAFETY: _exit is async-signal-safe.
    unsafe { libc::_exit(code) }
}

#[cfg(not(unix))]
fn exit_now(code: i32) -> ! {
    std::process::exit(code)
}
